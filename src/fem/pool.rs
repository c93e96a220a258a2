//! Spare large buffers (a factor's values, the element states) of the solvers of one
//! [`SolverSetup`], so a solver that needs a fresh buffer takes a released one instead of
//! allocating and filling a new one.
//!
//! A shared buffer is never overwritten, and a frame's FE updates start from shared states
//! (the free solve's, a location choice's): without the pool each made and filled a new
//! factor-sized and element-sized buffer. The pool belongs to the setup, which every solver
//! and state of a problem and its clones share (across the threads of the sensing stream
//! too), and all its buffers have the setup's lengths.

use super::tet4::ElementState;
use std::sync::{Arc, Mutex};

#[cfg(doc)]
use super::setup::SolverSetup;

/// At most this many spares are kept per buffer kind (a frame's solvers, two frames at once).
const SPARES_MAX: usize = 6;

/// Smaller buffers are not kept: filling them costs less than the lock.
const SPARE_MIN_BYTES: usize = 1 << 17;

/// The spare buffers of one setup's solvers, per element type. Their contents are stale:
/// every use overwrites what it reads (faer zeroes a factor's values before it factorizes,
/// and an element evaluation writes every element's force, stress, rotation and stored
/// tangent blocks).
#[derive(Default)]
pub(crate) struct BufferPool {
    factors: Mutex<Vec<Vec<f64>>>,
    elements: Mutex<Vec<Vec<ElementState>>>,
}

/// A buffer element type with spares in a [`BufferPool`].
pub(crate) trait Spare: Clone + Send + Sized + 'static {
    /// This type's spares in `pool`.
    fn spares(pool: &BufferPool) -> &Mutex<Vec<Vec<Self>>>;
}

impl Spare for f64 {
    fn spares(pool: &BufferPool) -> &Mutex<Vec<Vec<Self>>> {
        &pool.factors
    }
}

impl Spare for ElementState {
    fn spares(pool: &BufferPool) -> &Mutex<Vec<Vec<Self>>> {
        &pool.elements
    }
}

/// A large buffer of a solver that goes back to its pool when the last solver or state
/// holding it lets go.
#[derive(Clone)]
pub(crate) struct Pooled<T: Spare> {
    buf: Vec<T>,
    home: Arc<BufferPool>,
}

impl<T: Spare> Pooled<T> {
    /// An empty buffer that will go back to `pool`.
    pub(crate) fn empty(pool: &Arc<BufferPool>) -> Self {
        Self {
            buf: Vec::new(),
            home: pool.clone(),
        }
    }

    /// A spare buffer of `len` items from `pool` (stale contents), if it has one.
    pub(crate) fn spare(pool: &Arc<BufferPool>, len: usize) -> Option<Self> {
        if len * std::mem::size_of::<T>() < SPARE_MIN_BYTES {
            return None;
        }
        let mut spares = T::spares(pool).lock().ok()?;
        let i = spares.iter().position(|b| b.len() == len)?;
        Some(Self {
            buf: spares.swap_remove(i),
            home: pool.clone(),
        })
    }

    /// A buffer of `len` items to be overwritten whole: a spare one from `pool` (stale
    /// contents), else `len` copies of `fill`.
    pub(crate) fn fresh(pool: &Arc<BufferPool>, len: usize, fill: T) -> Self {
        Self::spare(pool, len).unwrap_or_else(|| Self {
            buf: vec![fill; len],
            home: pool.clone(),
        })
    }
}

impl<T: Spare> std::ops::Deref for Pooled<T> {
    type Target = Vec<T>;
    fn deref(&self) -> &Vec<T> {
        &self.buf
    }
}

impl<T: Spare> std::ops::DerefMut for Pooled<T> {
    fn deref_mut(&mut self) -> &mut Vec<T> {
        &mut self.buf
    }
}

impl<T: Spare> Drop for Pooled<T> {
    fn drop(&mut self) {
        if self.buf.len() * std::mem::size_of::<T>() < SPARE_MIN_BYTES {
            return;
        }
        if let Ok(mut spares) = T::spares(&self.home).lock() {
            if spares.len() < SPARES_MAX {
                spares.push(std::mem::take(&mut self.buf));
            }
        }
    }
}

/// `buf` to be overwritten whole: taken over if no other state shares it, else a fresh
/// buffer of the same length from its pool (no copy of contents about to be lost).
pub(crate) fn overwritten(buf: &mut Arc<Pooled<f64>>) -> &mut [f64] {
    if Arc::get_mut(buf).is_none() {
        let home = buf.home.clone();
        *buf = Arc::new(Pooled::fresh(&home, buf.len(), 0.0));
    }
    // Not shared now: no copy.
    &mut Arc::make_mut(buf).buf
}
