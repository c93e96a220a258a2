//! Frames sensed side by side ([`Sensor::sense_frames`]): each worker thread takes the next
//! frame as soon as it is free, and the reports are handed on in frame order.

use super::{CameraFrames, FrameReport, FrameStatus, Observation, SenseResult, Sensor};
#[cfg(feature = "parallel")]
use std::collections::BTreeMap;
#[cfg(feature = "parallel")]
use std::sync::atomic::{AtomicUsize, Ordering};
#[cfg(feature = "parallel")]
use std::sync::{mpsc, Condvar, Mutex};

/// A frame's observation and report.
#[cfg(feature = "parallel")]
type Sensed = (SenseResult<Observation>, FrameReport);

/// Frames [`Sensor::sense_frames`] senses side by side by default: one per thread of
/// rayon's pool (`RAYON_NUM_THREADS` or the cores), 1 without the `parallel` feature.
pub fn default_window() -> usize {
    #[cfg(feature = "parallel")]
    {
        rayon::current_num_threads()
    }
    #[cfg(not(feature = "parallel"))]
    {
        1
    }
}

impl Sensor {
    /// Observes and senses `frames` of `rec`, up to `window` frames at a time in parallel,
    /// and hands each observation and report to `emit` in frame order (`window` 0 or 1, or
    /// without the `parallel` feature: one at a time). Frames are independent, so a report
    /// is the one [`Sensor::sense`] gives for its frame alone, whatever the window and
    /// thread count. An unreadable frame gets [`FrameStatus::Unreadable`]. Stops at the
    /// first error of `emit` (frames already being sensed are finished and dropped).
    ///
    /// The frames go to `window` worker threads, each taking the next frame as soon as it
    /// is free and running at most `2 * window` frames ahead of the last one emitted; a
    /// frame's own parallel stages (element evaluations, location QPs) run on rayon's pool.
    /// Much of a frame's FE work is serial (sparse Cholesky, scatter), so on two cores two
    /// frames side by side get through more frames per second than one at a time, each
    /// taking longer.
    ///
    /// ```no_run
    /// # use softsense::sense::{Recording, SenseParams, Sensor};
    /// # use softsense::fem::model::Model;
    /// let rec = Recording::open("clouds/scenes/tip_weight".as_ref())?;
    /// let model = Model::load("meshes/models/robot.toml".as_ref(), None)?;
    /// let sensor = Sensor::new(model, rec.robot_from_camera.unwrap(), SenseParams::default());
    /// sensor.sense_frames(&rec, &rec.frames, 2, |_obs, report| {
    ///     println!("frame {}: {}", report.frame, report.status);
    ///     Ok::<(), std::io::Error>(())
    /// })?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn sense_frames<E>(
        &self,
        rec: &impl CameraFrames,
        frames: &[usize],
        window: usize,
        mut emit: impl FnMut(&SenseResult<Observation>, FrameReport) -> Result<(), E>,
    ) -> Result<(), E> {
        let one = |frame: usize| {
            let obs = self.observe(rec, frame);
            let report = match &obs {
                Ok(o) => self.sense(frame, o, rec.inputs_of(frame).as_ref()),
                Err(e) => FrameReport::empty(frame, FrameStatus::Unreadable(e.to_string())),
            };
            (obs, report)
        };
        #[cfg(feature = "parallel")]
        if window.min(frames.len()) > 1 {
            return in_order(frames, window.min(frames.len()), &one, emit);
        }
        #[cfg(not(feature = "parallel"))]
        let _ = window;
        for &frame in frames {
            let (obs, report) = one(frame);
            emit(&obs, report)?;
        }
        Ok(())
    }
}

/// How far the workers may run ahead of the output: the number of frames emitted so far
/// (`None` once the output has stopped), and a signal when it changes.
#[cfg(feature = "parallel")]
struct Gate {
    emitted: Mutex<Option<usize>>,
    changed: Condvar,
}

#[cfg(feature = "parallel")]
impl Gate {
    /// Waits until frame `i` is fewer than `lead` frames ahead of the output; false if the
    /// output stopped.
    fn wait_for(&self, i: usize, lead: usize) -> bool {
        let Ok(mut emitted) = self.emitted.lock() else {
            return false;
        };
        loop {
            match *emitted {
                None => return false,
                Some(n) if i < n + lead => return true,
                Some(_) => match self.changed.wait(emitted) {
                    Ok(e) => emitted = e,
                    Err(_) => return false,
                },
            }
        }
    }

    /// Records the output's progress (`None`: it stopped) and wakes the waiting workers.
    fn set(&self, emitted: Option<usize>) {
        if let Ok(mut e) = self.emitted.lock() {
            *e = emitted;
        }
        self.changed.notify_all();
    }
}

/// Senses `frames` with `one` on `workers` scoped threads, each taking the next frame index
/// from a shared counter and sending its result back; the results go to `emit` in frame
/// order, on the calling thread, as soon as each frame and those before it are done.
#[cfg(feature = "parallel")]
fn in_order<E>(
    frames: &[usize],
    workers: usize,
    one: &(impl Fn(usize) -> Sensed + Sync),
    mut emit: impl FnMut(&SenseResult<Observation>, FrameReport) -> Result<(), E>,
) -> Result<(), E> {
    let lead = 2 * workers;
    let next = AtomicUsize::new(0);
    let gate = Gate {
        emitted: Mutex::new(Some(0)),
        changed: Condvar::new(),
    };
    let (tx, rx) = mpsc::channel::<(usize, Sensed)>();
    std::thread::scope(|scope| {
        for _ in 0..workers {
            let (tx, next, gate) = (tx.clone(), &next, &gate);
            scope.spawn(move || loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&frame) = frames.get(i) else { break };
                if !gate.wait_for(i, lead) || tx.send((i, one(frame))).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        let mut ready = BTreeMap::new();
        let mut want = 0;
        for (i, done) in &rx {
            ready.insert(i, done);
            while let Some((obs, report)) = ready.remove(&want) {
                want += 1;
                if let Err(e) = emit(&obs, report) {
                    gate.set(None);
                    return Err(e);
                }
                gate.set(Some(want));
            }
        }
        Ok(())
    })
}
