//! The calibration result as written to `calibration.json`: its types live with the other
//! recording files in [`crate::recording::schema`].

pub use crate::recording::schema::{
    ActuatorCalibration, Calibration, CalibrationStatus, IterationReport,
};
