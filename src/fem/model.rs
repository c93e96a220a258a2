//! Model files (written next).
