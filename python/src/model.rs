//! The FE model: load, static solve, constraint-space compliance.

use crate::error;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use softsense::fem::model::Model as FeModel;
use softsense::fem::solve::{MappedPoint, PointLoad};

/// A finite-element model loaded from its TOML file, and that file when it describes the
/// model whole (not when `mesh` replaced the mesh it names): calls that read a model from
/// a file (`softsense hidden`) are given it.
#[pyclass(module = "softsense._softsense", frozen)]
pub struct Model(pub FeModel, Option<std::path::PathBuf>);

fn f64_bytes<'py>(py: Python<'py>, values: impl Iterator<Item = f64>) -> Bound<'py, PyBytes> {
    let b: Vec<u8> = values.flat_map(f64::to_le_bytes).collect();
    PyBytes::new(py, &b)
}

#[pymethods]
impl Model {
    /// Loads a model file (TOML); `mesh` replaces the mesh it names.
    #[staticmethod]
    #[pyo3(signature = (path, mesh=None))]
    fn load(
        py: Python<'_>,
        path: std::path::PathBuf,
        mesh: Option<std::path::PathBuf>,
    ) -> PyResult<Self> {
        let model = py
            .detach(|| FeModel::load(&path, mesh.as_deref()))
            .map_err(error)?;
        Ok(Model(model, mesh.is_none().then_some(path)))
    }

    /// The model file, or None when `mesh` replaced the mesh it names.
    #[getter]
    fn path(&self) -> Option<std::path::PathBuf> {
        self.1.clone()
    }

    /// Rest node positions (m) as little-endian f64 bytes, N x 3.
    fn nodes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        f64_bytes(
            py,
            self.0.problem.mesh.nodes_in_rest.iter().flatten().copied(),
        )
    }

    /// Tetrahedra as little-endian u64 node indices, M x 4.
    fn tets<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let b: Vec<u8> = self
            .0
            .problem
            .mesh
            .tets
            .iter()
            .flatten()
            .flat_map(|&i| (i as u64).to_le_bytes())
            .collect();
        PyBytes::new(py, &b)
    }

    /// Cable names, in model order.
    fn cables(&self) -> Vec<String> {
        self.0
            .problem
            .cables
            .iter()
            .map(|c| c.name.clone())
            .collect()
    }

    /// Pressure cavity names, in model order.
    fn cavities(&self) -> Vec<String> {
        (self.0.problem.cavities.iter())
            .map(|c| c.name.clone())
            .collect()
    }

    /// Static equilibrium under the model's own loads and actuator inputs plus `loads`, a
    /// list of `(node, fx, fy, fz)` in newtons, and `pressures`, a dict of cavity name to
    /// pressure (Pa). Returns a dict: `displacement` and `positions` (f64 bytes, N x 3),
    /// `converged`, `iterations`, `residuals`, per cable `cable_tension` (N),
    /// `cable_shortening` (m), `cable_slack`, per cavity `cavity_pressure` (Pa) and
    /// `cavity_volume_change` (m^3); `warning` when the displacement is outside small
    /// strain's validity.
    #[pyo3(signature = (loads=None, pressures=None))]
    fn solve<'py>(
        &self,
        py: Python<'py>,
        loads: Option<Vec<(usize, f64, f64, f64)>>,
        pressures: Option<std::collections::BTreeMap<String, f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let nodes = self.0.problem.mesh.nodes_in_rest.len();
        let mut problem = self.0.problem.clone();
        let inputs: Vec<softsense::recording::CavityInput> = (pressures.unwrap_or_default())
            .into_iter()
            .map(|(name, p)| softsense::recording::CavityInput {
                name,
                pressure: Some(p),
                volume: None,
            })
            .collect();
        softsense::fem::solve::apply_cavity_inputs(&mut problem.cavities, &inputs)
            .map_err(error)?;
        for (node, fx, fy, fz) in loads.unwrap_or_default() {
            if node >= nodes {
                return Err(error(format!(
                    "load on node {node}: the mesh has {nodes} nodes"
                )));
            }
            problem.loads.push(PointLoad {
                at: MappedPoint::node(node),
                force: [fx, fy, fz],
            });
        }
        let newton = self.0.newton.clone();
        let sol = py.detach(|| problem.solve_static(&newton)).map_err(error)?;
        let out = PyDict::new(py);
        out.set_item(
            "displacement",
            f64_bytes(py, sol.displacement.iter().flatten().copied()),
        )?;
        out.set_item(
            "positions",
            f64_bytes(py, sol.positions.iter().flatten().copied()),
        )?;
        out.set_item("converged", sol.converged)?;
        out.set_item("iterations", sol.iterations)?;
        out.set_item("residuals", sol.residuals.clone())?;
        out.set_item("cable_tension", sol.cable_tension.clone())?;
        out.set_item("cable_shortening", sol.cable_shortening.clone())?;
        out.set_item("cable_slack", sol.cable_slack.clone())?;
        out.set_item("cavity_pressure", sol.cavity_pressure.clone())?;
        out.set_item("cavity_volume_change", sol.cavity_volume_change.clone())?;
        out.set_item("warning", self.0.validity_warning(&sol.displacement))?;
        Ok(out)
    }

    /// The constraint-space compliance W = H K⁻¹ Hᵀ at the rest state (thesis 4.2), as
    /// `softsense fem compliance` computes it: a dict of `w` (f64 bytes, rows x rows, m/N),
    /// `delta_free` (m per row) and `kinds` (per row: "Effector", "Actuator" or "Force").
    fn compliance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.0;
        let c = py
            .detach(|| {
                let x = m.problem.mesh.nodes_in_rest.clone();
                let rows = m.rows(&x);
                m.problem.solver()?.compliance_at(&x, &rows)
            })
            .map_err(error)?;
        let n = c.w.nrows();
        let out = PyDict::new(py);
        out.set_item(
            "w",
            f64_bytes(
                py,
                (0..n)
                    .flat_map(|i| (0..n).map(move |j| (i, j)))
                    .map(|(i, j)| c.w[(i, j)]),
            ),
        )?;
        out.set_item("delta_free", c.delta_free.clone())?;
        let kinds: Vec<String> = c.kinds.iter().map(|k| format!("{k:?}")).collect();
        out.set_item("kinds", kinds)?;
        Ok(out)
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Model>()
}
