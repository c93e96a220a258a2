//! The finite-element core: tetrahedral meshes, corotational and Neo-Hookean linear
//! tetrahedra, sparse
//! Cholesky statics and constraint-space compliance (thesis 2.2, design section 3).
//!
//! Everything is `f64` and SI inside (m, kg, s, N, Pa); model files may be written in the
//! mm/kg/s units of SOFA scenes and are converted when loaded ([`model`]).
//!
//! ```
//! use softsense::fem::{mesh::TetMesh, material::Material};
//! use softsense::fem::solve::{Formulation, MappedPoint, PointLoad, Problem};
//! // One unit tetrahedron, three nodes fixed, a force on the fourth.
//! let mesh = TetMesh::new(
//!     vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
//!     vec![[0, 1, 2, 3]],
//! ).unwrap();
//! let mut p = Problem::new(mesh, Material::new(1.0e4, 0.3).unwrap(), Formulation::SmallStrain);
//! p.fixed = vec![0, 1, 2];
//! p.loads.push(PointLoad { at: MappedPoint::node(3), force: [0.0, 0.0, -1.0] });
//! let sol = p.solve_static(&Default::default()).unwrap();
//! assert!(sol.displacement[3][2] < 0.0);
//! ```

// `!(x > 0.0)` is used on purpose: it also rejects NaN, which `x <= 0.0` would let through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod assembly;
pub mod beam;
pub mod bind;
mod cable;
pub mod cavity;
pub mod constraint;
mod factor;
pub mod material;
pub mod mesh;
pub mod mesher;
pub mod meshio;
pub mod model;
pub mod neohookean;
mod newton;
mod pool;
pub mod prestress;
mod problem;
mod setup;
pub mod shell;
pub mod solve;
pub mod surfaceio;
pub mod tet4;
pub mod tet_quality;
mod workspace;

use thiserror::Error;

/// Errors of the FE core: bad meshes and files, bad models, singular or failing solves.
#[derive(Debug, Error)]
pub enum FemError {
    /// A point to bind is farther from the surface than allowed.
    #[error("point {name:?} at {position:?} m is {distance:.4} m from the surface (more than {max_distance} m)")]
    OffSurface {
        /// The point's name (a marker's as tracked, a calibration `feature N`, a painted
        /// marker's).
        name: String,
        /// Where it was given (m, model frame).
        position: [f64; 3],
        /// Its distance to the surface (m; NaN for a non-finite position).
        distance: f64,
        /// The largest distance allowed (m).
        max_distance: f64,
    },
    /// A path given as a model file that is a folder or not TOML text (arguments swapped,
    /// or a cloud given as the model).
    #[error("{path}: {problem}")]
    NotAModel {
        /// The path given.
        path: std::path::PathBuf,
        /// What it is instead, and what to give.
        problem: String,
    },
    /// An output file could not be written (it names the file).
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: String,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// An error in reading a mesh or model file, with the file's name.
    #[error("{path}: {source}")]
    InFile {
        /// The file.
        path: String,
        /// What is wrong with it.
        source: Box<FemError>,
    },
    /// A mesh file is malformed (truncated, inconsistent counts, bad numbers).
    #[error("mesh parse error: {0}")]
    Parse(String),
    /// The mesher (gmsh) is missing or failed.
    #[error("meshing: {0}")]
    Mesher(String),
    /// The mesh file format (or its encoding) is not supported.
    #[error("unsupported mesh format: {0}")]
    Unsupported(String),
    /// A cell type other than the linear tetrahedron.
    #[error("unsupported cell type {cell_type} in cell {cell} (only linear tetrahedra, and in legacy VTK triangles, lines and vertices)")]
    UnsupportedCell {
        /// The 0-based cell index in the file.
        cell: usize,
        /// The VTK or Gmsh type code.
        cell_type: i64,
    },
    /// A tetrahedral mesh was asked of a file that holds a triangle surface.
    #[error("the mesh is a triangle surface ({triangles} triangles, no tetrahedra): to model it as a thin body, give `shell = {{ thickness = ..., layers = 1, side = \"outside\" }}` in the model file's [mesh] table")]
    SurfaceNotVolume {
        /// Triangles in the file.
        triangles: usize,
    },
    /// A tetrahedron references a node that does not exist.
    #[error("tetrahedron {tet} references node {node} but the mesh has {nodes} nodes")]
    BadIndex {
        /// The tetrahedron.
        tet: usize,
        /// The offending node index.
        node: usize,
        /// Number of nodes.
        nodes: usize,
    },
    /// A mesh without nodes or tetrahedra, or with non-finite coordinates.
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
    /// A tetrahedron with (near) zero volume.
    #[error("degenerate tetrahedron {tet}: signed volume {volume:e}")]
    DegenerateElement {
        /// The tetrahedron.
        tet: usize,
        /// Its signed volume.
        volume: f64,
    },
    /// A tetrahedron with negative volume (rest shape) or inverted by the deformation.
    #[error("inverted tetrahedron {tet}: det F or signed volume {volume:e}")]
    InvertedElement {
        /// The tetrahedron.
        tet: usize,
        /// Its signed volume (rest) or det F (deformed).
        volume: f64,
    },
    /// Invalid material parameters.
    #[error("invalid material: {0}")]
    Material(String),
    /// The model does not fix enough nodes to remove rigid motions, or a small dense
    /// system (cable or actuator compliance) is singular.
    #[error("singular system: {0}")]
    Singular(String),
    /// The tangent stiffness is not positive definite: faer's sparse Cholesky met a
    /// non-positive pivot.
    #[error("tangent stiffness is not positive definite (non-positive pivot at column {pivot} of the permuted system)")]
    NotPositiveDefinite {
        /// The column of the fill-reducing permuted system with the non-positive pivot.
        pivot: usize,
    },
    /// The Newton iteration did not converge.
    #[error("Newton did not converge in {iterations} iterations (residual {residual:e})")]
    NoConvergence {
        /// Iterations done.
        iterations: usize,
        /// Final residual norm (N).
        residual: f64,
    },
    /// A point could not be located in the mesh.
    #[error("point {point:?} is outside the mesh (distance {distance:e} m)")]
    PointOutside {
        /// The point.
        point: [f64; 3],
        /// Its distance to the nearest tetrahedron (approximate).
        distance: f64,
    },
    /// The model file is invalid.
    #[error("invalid model: {0}")]
    Model(String),
    /// Cable inputs name a cable the model does not have.
    #[error("no cable named {name:?}")]
    NoSuchCable {
        /// The name given.
        name: String,
    },
    /// A cable input gives both, or neither, of its shortening and its force.
    #[error("cable {name:?}: give exactly one of shorten, force")]
    CableInputNotOne {
        /// The cable.
        name: String,
    },
    /// faer could not allocate or index the sparse system.
    #[error("sparse linear algebra: {0}")]
    Linalg(#[from] faer::sparse::FaerError),
    /// The stiffness matrix has more stored entries than the element slot index can hold.
    #[error("stiffness matrix too large: {entries} stored entries")]
    TooLarge {
        /// Stored entries of the upper triangle.
        entries: usize,
    },
    /// A solve or compliance needs the factor of the current tangent, and there is none
    /// (not factorized since the last assembly, or the factorization failed).
    #[error("no factorization of the current tangent")]
    NoFactor,
    /// The symbolic Cholesky is simplicial where the supernodal structure is needed.
    #[error("the Cholesky factor is not supernodal")]
    NotSupernodal,
}

impl From<faer::linalg::solvers::LltError> for FemError {
    fn from(e: faer::linalg::solvers::LltError) -> Self {
        match e {
            faer::linalg::solvers::LltError::NonPositivePivot { index } => {
                Self::NotPositiveDefinite { pivot: index }
            }
        }
    }
}

impl crate::io::InFile for FemError {
    fn names_file(&self) -> bool {
        matches!(
            self,
            FemError::File { .. } | FemError::InFile { .. } | FemError::Write(_)
        )
    }

    fn wrap_in_file(self, path: &std::path::Path) -> Self {
        FemError::InFile {
            path: path.display().to_string(),
            source: Box::new(self),
        }
    }
}

/// `Result` with [`FemError`].
pub type FemResult<T> = std::result::Result<T, FemError>;
