//! Baselines of SPEC 12 behind the crate's types: traditional Canny, FAST-9, ORB and
//! ORB-SLAM's extractor (the paper's comparator).

pub mod canny;
pub mod fast;
pub mod orb;
pub mod orbslam;
