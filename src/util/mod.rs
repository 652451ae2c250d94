//! Small helpers that belong to no one domain module and that domain modules of every layer use:
//! they import nothing of the crate, so any module may import them without closing a circle.

pub mod fs;
pub mod text;
