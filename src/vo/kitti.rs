//! KITTI odometry files: `calib.txt` (projection matrices) and poses (one
//! 3x4 row-major camera-to-world matrix per line), read and written.

use super::{Pose, VoError};
use nalgebra::{Matrix3, Matrix3x4, Vector3};
use std::path::Path;

/// Pinhole intrinsics of the rectified left camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x.
    pub cx: f64,
    /// Principal point y.
    pub cy: f64,
}

impl Intrinsics {
    /// Normalised image coordinates of pixel `(u, v)`: `K^-1 (u, v, 1)`.
    pub fn normalise(&self, u: f64, v: f64) -> nalgebra::Vector2<f64> {
        nalgebra::Vector2::new((u - self.cx) / self.fx, (v - self.cy) / self.fy)
    }

    /// The mean focal length (pixel thresholds to normalised units).
    pub fn focal(&self) -> f64 {
        0.5 * (self.fx + self.fy)
    }
}

/// The camera calibration of a sequence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calib {
    /// P0, the left gray camera's 3x4 projection matrix.
    pub p0: Matrix3x4<f64>,
}

impl Calib {
    /// K from P0 (`fx = P[0][0]`, `fy = P[1][1]`, `cx = P[0][2]`, `cy = P[1][2]`).
    pub fn intrinsics(&self) -> Intrinsics {
        let p = &self.p0;
        Intrinsics { fx: p[(0, 0)], fy: p[(1, 1)], cx: p[(0, 2)], cy: p[(1, 2)] }
    }
}

fn parse_err(path: &Path, line: usize, reason: impl Into<String>) -> VoError {
    VoError::Parse { path: path.to_path_buf(), line, reason: reason.into() }
}

/// Twelve numbers of one line (`line` 1-based, for the error).
fn twelve(path: &Path, line: usize, tokens: &[&str]) -> Result<[f64; 12], VoError> {
    if tokens.len() != 12 {
        return Err(parse_err(path, line, format!("expected 12 numbers, found {}", tokens.len())));
    }
    let mut v = [0.0; 12];
    for (k, t) in tokens.iter().enumerate() {
        v[k] = t.parse::<f64>().map_err(|_| parse_err(path, line, format!("`{t}` is not a number")))?;
        if !v[k].is_finite() {
            return Err(parse_err(path, line, format!("`{t}` is not finite")));
        }
    }
    Ok(v)
}

/// Parses a KITTI `calib.txt`. Rows are labelled (`P0: ...`, as KITTI ships
/// it) or unlabelled (12 numbers each, P0 first, as in the project's KITTI test data). With
/// labels, the `P0:` row is used; without, the first row.
///
/// ```
/// use lfast::vo::kitti::parse_calib;
/// let c = parse_calib("P0: 700 0 600 0 0 710 180 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\n", "calib.txt".as_ref()).unwrap();
/// assert_eq!((c.intrinsics().fx, c.intrinsics().cy), (700.0, 180.0));
/// ```
pub fn parse_calib(text: &str, path: &Path) -> Result<Calib, VoError> {
    let mut first_unlabelled = None;
    let mut labelled = false;
    for (i, line) in text.lines().enumerate() {
        let toks: Vec<&str> = line.split_whitespace().collect();
        let Some(first) = toks.first() else { continue };
        if first.starts_with('#') {
            continue;
        }
        if let Some(label) = first.strip_suffix(':') {
            labelled = true;
            if label == "P0" {
                return calib_from(path, i + 1, twelve(path, i + 1, &toks[1..])?);
            }
        } else if first_unlabelled.is_none() {
            first_unlabelled = Some((i + 1, toks));
        }
    }
    match first_unlabelled {
        Some((line, toks)) if !labelled => calib_from(path, line, twelve(path, line, &toks)?),
        _ if labelled => Err(parse_err(path, 0, "no `P0:` row among the labelled rows")),
        _ => Err(parse_err(path, 0, "no projection matrix (the file is empty)")),
    }
}

fn calib_from(path: &Path, line: usize, v: [f64; 12]) -> Result<Calib, VoError> {
    let c = Calib { p0: Matrix3x4::from_row_slice(&v) };
    let k = c.intrinsics();
    if k.fx <= 0.0 || k.fy <= 0.0 {
        return Err(parse_err(
            path,
            line,
            format!("P0 has focal lengths {} and {}; both must be positive", k.fx, k.fy),
        ));
    }
    Ok(c)
}

/// Reads and parses `path` as a calibration file.
pub fn read_calib(path: &Path) -> Result<Calib, VoError> {
    parse_calib(&read(path)?, path)
}

fn read(path: &Path) -> Result<String, VoError> {
    std::fs::read_to_string(path).map_err(|source| crate::Error::Io { path: path.to_path_buf(), source }.into())
}

/// Parses KITTI poses: one line per frame, 12 numbers, the row-major 3x4
/// `[R | t]` mapping camera coordinates to world coordinates. Blank lines and
/// `#` comments are skipped (as numpy's `loadtxt`, which evo uses, does).
///
/// ```
/// use lfast::vo::kitti::parse_poses;
/// let p = parse_poses("1 0 0 1.5 0 1 0 -2 0 0 1 3\n", "poses.txt".as_ref()).unwrap();
/// assert_eq!(p[0].translation, nalgebra::Vector3::new(1.5, -2.0, 3.0));
/// ```
pub fn parse_poses(text: &str, path: &Path) -> Result<Vec<Pose>, VoError> {
    let mut poses = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        let toks: Vec<&str> = line.split_whitespace().collect();
        if toks.is_empty() {
            continue;
        }
        let v = twelve(path, i + 1, &toks)?;
        poses.push(Pose {
            rotation: Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]),
            translation: Vector3::new(v[3], v[7], v[11]),
        });
    }
    Ok(poses)
}

/// Reads and parses `path` as a poses file.
pub fn read_poses(path: &Path) -> Result<Vec<Pose>, VoError> {
    parse_poses(&read(path)?, path)
}

/// C's `%.{prec}e` (`1.000000e+00`), the notation of KITTI's own files.
pub fn c_exp(v: f64, prec: usize) -> String {
    let s = format!("{v:.prec$e}");
    match s.split_once('e') {
        Some((m, e)) => {
            let (sign, digits) = e.strip_prefix('-').map_or(("+", e), |d| ("-", d));
            format!("{m}e{sign}{digits:0>2}")
        }
        None => s, // NaN, inf
    }
}

/// Poses in KITTI format, 12 numbers a line in `%.9e` (more digits than
/// KITTI's `%e`, so a round trip loses nothing that matters at 1e-4 m).
pub fn format_poses(poses: &[Pose]) -> String {
    let mut s = String::with_capacity(poses.len() * 200);
    for p in poses {
        let (r, t) = (&p.rotation, &p.translation);
        let row = [
            r[(0, 0)],
            r[(0, 1)],
            r[(0, 2)],
            t.x,
            r[(1, 0)],
            r[(1, 1)],
            r[(1, 2)],
            t.y,
            r[(2, 0)],
            r[(2, 1)],
            r[(2, 2)],
            t.z,
        ];
        let cells: Vec<String> = row.iter().map(|v| c_exp(*v, 9)).collect();
        s.push_str(&cells.join(" "));
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHARED_STYLE: &str = "7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 \
        0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 0.000000000000e+00 \
        0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n\
        7.188560000000e+02 0 6.071928000000e+02 -3.861448000000e+02 0 7.188560000000e+02 1.852157000000e+02 0 0 0 1 0\n";

    #[test]
    fn calib_unlabelled_rows_take_the_first() {
        let k = parse_calib(SHARED_STYLE, Path::new("c")).unwrap().intrinsics();
        assert_eq!(k, Intrinsics { fx: 718.856, fy: 718.856, cx: 607.1928, cy: 185.2157 });
    }

    #[test]
    fn calib_labelled_rows_take_p0_wherever_it_is() {
        let t = "P1: 1 0 2 0 0 1 3 0 0 0 1 0\nP0: 500 0 320 0 0 510 240 0 0 0 1 0\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\n";
        let k = parse_calib(t, Path::new("c")).unwrap().intrinsics();
        assert_eq!(k, Intrinsics { fx: 500.0, fy: 510.0, cx: 320.0, cy: 240.0 });
    }

    #[test]
    fn calib_errors_name_the_line_and_the_problem() {
        let e = parse_calib("P1: 1 0 2 0 0 1 3 0 0 0 1 0\n", Path::new("c.txt")).unwrap_err().to_string();
        assert!(e.contains("no `P0:`"), "{e}");
        let e = parse_calib("\n1 2 3\n", Path::new("c.txt")).unwrap_err().to_string();
        assert!(e.contains("c.txt, line 2") && e.contains("expected 12 numbers, found 3"), "{e}");
        let e = parse_calib("P0: 1 0 2 0 0 1 3 0 0 0 x 0\n", Path::new("c.txt")).unwrap_err().to_string();
        assert!(e.contains("`x` is not a number"), "{e}");
        let e = parse_calib("-1 0 2 0 0 1 3 0 0 0 1 0\n", Path::new("c.txt")).unwrap_err().to_string();
        assert!(e.contains("must be positive"), "{e}");
        assert!(parse_calib("", Path::new("c.txt")).is_err());
    }

    #[test]
    fn poses_parse_row_major_and_round_trip() {
        let t = "# header\n1 2 3 4 5 6 7 8 9 10 11 12\n\n9.990498e-01 -1.649780e-03 4.355194e-02 5.154656e-02 \
                 1.760423e-03 9.999953e-01 -2.502237e-03 -2.424883e-02 -4.354760e-02 2.576529e-03 9.990480e-01 1.000725e+00\n";
        let p = parse_poses(t, Path::new("p")).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].rotation, Matrix3::new(1.0, 2.0, 3.0, 5.0, 6.0, 7.0, 9.0, 10.0, 11.0));
        assert_eq!(p[0].translation, Vector3::new(4.0, 8.0, 12.0));
        assert_eq!(p[1].translation, Vector3::new(5.154656e-02, -2.424883e-02, 1.000725));
        assert_eq!(p[1].rotation[(2, 0)], -4.354760e-02);
        let back = parse_poses(&format_poses(&p), Path::new("p")).unwrap();
        assert_eq!(back, p);
        assert!(format_poses(&p[..1]).starts_with("1.000000000e+00 2.000000000e+00 3.000000000e+00 4.000000000e+00 "));
    }

    #[test]
    fn poses_errors_name_the_line() {
        let e = parse_poses("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0\n", Path::new("p.txt")).unwrap_err().to_string();
        assert!(e.contains("p.txt, line 2") && e.contains("found 3"), "{e}");
        let e = parse_poses("1 0 0 0 0 1 0 0 0 0 1 nan\n", Path::new("p.txt")).unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
    }

    #[test]
    fn c_exp_matches_printf() {
        assert_eq!(c_exp(1.0, 6), "1.000000e+00");
        assert_eq!(c_exp(-0.0123, 3), "-1.230e-02");
        assert_eq!(c_exp(123456.0, 2), "1.23e+05");
        assert_eq!(c_exp(1e-120, 1), "1.0e-120");
    }
}
