//! SPEC.md quotes counts measured on KITTI seq01 frame 20 by an independent
//! implementation of the spec. Matching them checks SPEC 0-9 end to end.

mod common;

use lfast::cpu::{
    corner_nms::corner_nms,
    edge_map,
    lfast::{LfastParams, lfast},
    response::responses,
};
use lfast::{Config, Mode};

#[test]
fn kitti_frame_20_matches_spec_counts() {
    let Some(path) = common::shared("kitti/seq01_000000-000050/image_0/000020.png") else { return };
    let img = lfast::image::load_gray(&path).unwrap();
    // the paper's parameters (support 4), which SPEC's counts were measured with
    let cfg = Config::paper();
    let em = edge_map(&img, &cfg);
    let n_edges = em.edges.data.iter().filter(|&&v| v == 255).count();
    assert_eq!(n_edges, 14658, "edge pixels");

    let params = |mode| LfastParams { mode, ..LfastParams::from_config(&cfg) };
    let paper = lfast(&em.edges, None, &params(Mode::Paper));
    assert_eq!(paper.len(), 3366, "Paper-mode candidates");
    let branch = lfast(&em.edges, None, &params(Mode::Branch));
    assert_eq!(branch.len(), 1331, "Branch-mode candidates");

    let resp = responses(&em.denoised, &branch);
    assert_eq!(corner_nms(img.width, img.height, &branch, &resp, 1).len(), 751, "after corner NMS r = 1");
    assert_eq!(corner_nms(img.width, img.height, &branch, &resp, 3).len(), 369, "after corner NMS r = 3");

    // FAST-9 on the same frame finds 1885 (SPEC 8)
}
