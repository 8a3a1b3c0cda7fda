//! Baselines of SPEC 12 behind the crate's types: traditional Canny, FAST-9 and ORB.

pub mod canny;
pub mod fast;
pub mod orb;
