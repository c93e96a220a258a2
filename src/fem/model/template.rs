//! A model file written for a user's own robot (`softsense model new`): every key present
//! or shown commented out, each with its unit in the file's unit system, so the file is
//! its own reference (docs/model-format.md has the rest).

use super::spec::{CableSpec, Units};
use std::fmt::Write;

/// What a new model file says.
#[derive(Debug, Clone)]
pub struct ModelTemplate {
    /// `"mm-kg-s"` or `"SI"`.
    pub units: String,
    /// The mesh file, relative to the model file.
    pub mesh: String,
    /// Where the mesh came from (a comment).
    pub source: String,
    /// Young's modulus (the file's pressure unit).
    pub young: f64,
    /// Poisson ratio.
    pub poisson: f64,
    /// Density (kg/m^3; written in the file's density unit), unless `total_mass` is given.
    pub density_si: f64,
    /// Total mass (kg), spread by volume, instead of the density.
    pub total_mass: Option<f64>,
    /// Gravity (the file's length unit per s^2).
    pub gravity: [f64; 3],
    /// Fixed boxes (file units), each with a comment saying where it came from.
    pub fixed: Vec<([[f64; 3]; 2], String)>,
    /// Cables (file units).
    pub cables: Vec<CableSpec>,
    /// Cavities: name and surface file relative to the model file.
    pub cavities: Vec<(String, String)>,
    /// Effectors: name and position (file units).
    pub effectors: Vec<(String, [f64; 3])>,
    /// Regions of another modulus: box (file units) and Young's modulus (pressure unit).
    pub regions: Vec<([[f64; 3]; 2], f64)>,
}

fn v3(p: [f64; 3]) -> String {
    format!("[{}, {}, {}]", num(p[0]), num(p[1]), num(p[2]))
}

/// A number as TOML reads it back exactly (shortest round-trip form, always a float).
fn num(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

impl ModelTemplate {
    /// The model file's text.
    pub fn to_toml(&self) -> String {
        let si = self.units == "SI";
        let (len, pressure, density_unit, force) = match si {
            true => ("m", "Pa", "kg/m^3", "N"),
            false => ("mm", "kPa", "kg/mm^3", "mN"),
        };
        let density = self.density_si / Units::parse(&self.units).map_or(1.0, |u| u.density);
        let mut s = String::new();
        let w = &mut s;
        let _ = writeln!(
            w,
            "# A softsense model of {} (written by `softsense model new`).",
            self.source
        );
        let _ = writeln!(
            w,
            "# Every key: docs/model-format.md. Check it with `softsense model check model.toml`."
        );
        let _ = writeln!(w, "# Units: lengths in {len}, pressures and moduli in {pressure}, forces in {}, mass in kg.", force);
        let _ = writeln!(w, "units = \"{}\"", self.units);
        let _ = writeln!(w, "formulation = \"corotational\"   # or \"small-strain\", \"neo-hookean\" (large strain)");
        let _ = writeln!(
            w,
            "gravity = {}   # {len}/s^2; the robot frame is the mesh's frame",
            v3(self.gravity)
        );
        let _ = writeln!(
            w,
            "# base_stiffness = 1000.0   # N/m: fixed nodes on springs instead of clamped"
        );
        let _ = writeln!(
            w,
            "\n[mesh]\npath = \"{}\"   # tetrahedra, relative to this file",
            self.mesh
        );
        let _ = writeln!(
            w,
            "\n# [placement]   # applied to the mesh before anything else, in {len}"
        );
        let _ = writeln!(w, "# scale = 1.0\n# rotate_deg = [0.0, 0.0, 0.0]   # about x, then y, then z\n# translate = [0.0, 0.0, 0.0]");
        let _ = writeln!(w, "\n[material]\nyoung = {}   # {pressure}: calibrate it from a known weight (docs/your-robot.md)", num(self.young));
        let _ = writeln!(w, "poisson = {}", num(self.poisson));
        match self.total_mass {
            Some(m) => {
                let _ = writeln!(
                    w,
                    "\n[mass]\ntotal = {}   # kg, spread by volume; or density",
                    num(m)
                );
            }
            None => {
                let _ = writeln!(
                    w,
                    "\n[mass]\ndensity = {}   # {density_unit} ({} kg/m^3); or total = KG",
                    num(density),
                    num(self.density_si)
                );
            }
        }
        for (b, why) in &self.fixed {
            let _ = writeln!(
                w,
                "\n[[fixed]]   # {why}\nbox = [{}, {}]   # {len}, [min, max]",
                v3(b[0]),
                v3(b[1])
            );
        }
        for c in &self.cables {
            let _ = writeln!(w, "\n[[cables]]\nname = \"{}\"", c.name);
            let _ = writeln!(
                w,
                "pull = {}   # {len}: fixed in space, where the cable leaves the body",
                v3(c.pull)
            );
            let _ = writeln!(
                w,
                "attach = [   # {len}: the points it runs through, from the pull point outward"
            );
            for a in &c.attach {
                let _ = writeln!(w, "    {},", v3(*a));
            }
            let _ = writeln!(
                w,
                "]\n# shorten = 1.0   # {len}: displacement control; or force = N (tension)"
            );
        }
        for (name, surface) in &self.cavities {
            let _ = writeln!(w, "\n[[cavities]]\nname = \"{name}\"\nsurface = \"{surface}\"   # its closed surface, relative to this file");
            let _ = writeln!(
                w,
                "pressure = 0.0   # {pressure}; or volume = {len}^3 (volume control)"
            );
        }
        for (name, at) in &self.effectors {
            let _ = writeln!(
                w,
                "\n[[effectors]]\nname = \"{name}\"\nat = {}   # {len}",
                v3(*at)
            );
        }
        for (b, young) in &self.regions {
            let _ = writeln!(
                w,
                "\n[[regions]]   # tetrahedra whose centroid is in the box"
            );
            let _ = writeln!(w, "box = [{}, {}]   # {len}", v3(b[0]), v3(b[1]));
            let _ = writeln!(w, "young = {}   # {pressure}", num(*young));
        }
        if self.regions.is_empty() {
            let _ = writeln!(w, "\n# [[regions]]   # a part of another modulus (tetrahedra whose centroid is in the box)");
            let _ = writeln!(
                w,
                "# box = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]\n# young = 1.0   # {pressure}"
            );
        }
        let _ = writeln!(
            w,
            "\n# [[force_points]]   # candidate places of an external force (sense adds contacts)"
        );
        let _ = writeln!(w, "# name = \"hook\"\n# at = [0.0, 0.0, 0.0]");
        let _ = writeln!(
            w,
            "\n# [newton]\n# max_iterations = 50\n# load_steps = 1\n# rel_tol = 1e-10"
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::super::ModelSpec;
    use super::*;

    #[test]
    fn a_written_template_parses_back_to_the_same_numbers() {
        let t = ModelTemplate {
            units: "mm-kg-s".into(),
            mesh: "mesh.vtu".into(),
            source: "finger.stl".into(),
            young: 0.1 + 0.2,
            poisson: 0.45,
            density_si: 1070.0,
            total_mass: None,
            gravity: [0.0, 0.0, -9810.0],
            fixed: vec![([[-1.0, -1.0, -1.0], [1.0, 1.0, 2.0]], "z below 2".into())],
            cables: vec![CableSpec {
                name: "c".into(),
                pull: [0.0, 0.0, 1.0],
                attach: vec![[0.0, 0.0, 2.0], [0.0, 1.0, 3.0]],
                shorten: None,
                force: None,
            }],
            cavities: vec![("air".into(), "cavity_air.stl".into())],
            effectors: vec![("tip".into(), [0.0, 0.0, 90.0])],
            regions: vec![([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]], 1500.0)],
        };
        let spec: ModelSpec = toml::from_str(&t.to_toml()).unwrap();
        assert_eq!(spec.material.young, 0.1 + 0.2);
        assert_eq!(spec.mass.unwrap().density, Some(1070.0 / 1e9));
        assert_eq!(
            spec.fixed[0].r#box,
            Some([[-1.0, -1.0, -1.0], [1.0, 1.0, 2.0]])
        );
        assert_eq!(spec.cables[0].attach.len(), 2);
        assert_eq!(spec.cavities[0].surface.as_deref(), Some("cavity_air.stl"));
        assert_eq!(spec.effectors[0].at, [0.0, 0.0, 90.0]);
        assert_eq!(
            (spec.regions[0].r#box[1], spec.regions[0].young),
            ([1.0, 2.0, 3.0], 1500.0)
        );
    }
}
