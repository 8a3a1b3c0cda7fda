//! `lfast._lfast`: the native half of the Python package. Arrays in, arrays
//! out; the OpenCV types (cv2.KeyPoint, cv2.DMatch) are made by the pure-Python
//! wrapper in `lfast/__init__.py`, so this module never imports cv2.
//!
//! Every entry point converts its inputs while it holds the GIL, then releases
//! it (`Python::detach`) for the work, so a thread pool scales. Errors are
//! Python exceptions naming what was wrong; nothing here panics on bad input.
//! The work is the library's: luma conversion ([`lfast::image::luma_bt601`]),
//! config validation ([`lfast::Config::validate`]), detection
//! ([`lfast::Detector`]), description of given keypoints
//! ([`lfast::cpu::CpuDetector::compute`]), matching
//! ([`lfast::cpu::matcher::match_descriptors`]) and the output files
//! ([`lfast::io`]).

use lfast::cpu::CpuDetector;
use lfast::cpu::matcher::{MatchOptions, match_descriptors};
use lfast::image::{check_size, luma_bt601};
use lfast::{Backend, Config, Descriptor, Detector, KeyPoint, Plane};
use numpy::ndarray::{Array2, ArrayView2, ArrayView3};
use numpy::{
    IntoPyArray, PyArray2, PyArrayDescrMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PyString};
use std::path::PathBuf;

pyo3::create_exception!(
    _lfast,
    GpuError,
    PyRuntimeError,
    "The GPU could not run the request (no adapter, device lost, out of memory, over a device limit)."
);

/// The library's error as the Python exception a caller expects.
fn to_py(e: lfast::Error) -> PyErr {
    use lfast::Error as E;
    let msg = e.to_string();
    match e {
        E::InvalidConfig { .. }
        | E::ConfigParse { .. }
        | E::InvalidImage { .. }
        | E::MaskSize { .. }
        | E::InvalidKeypoint { .. }
        | E::Image { .. }
        | E::Pattern { .. }
        | E::Recording { .. }
        | E::Message { .. } => PyValueError::new_err(msg),
        E::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(msg),
        E::Io { .. } => PyOSError::new_err(msg),
        E::NoAdapter { .. } | E::GpuLimits { .. } | E::GpuOutOfMemory { .. } | E::DeviceLost { .. } | E::Gpu { .. } => {
            GpuError::new_err(msg)
        }
        _ => PyRuntimeError::new_err(msg),
    }
}

// ---------------------------------------------------------------- images

/// A pixel type accepted as input, and its 8-bit value (SPEC 0: `v >> 8` for 16-bit).
trait Sample: numpy::Element + Copy {
    fn to_u8(self) -> u8;
}
impl Sample for u8 {
    fn to_u8(self) -> u8 {
        self
    }
}
impl Sample for u16 {
    fn to_u8(self) -> u8 {
        (self >> 8) as u8
    }
}
impl Sample for bool {
    fn to_u8(self) -> u8 {
        if self { 255 } else { 0 }
    }
}

fn gray_from_2d<T: Sample>(v: ArrayView2<'_, T>) -> Vec<u8> {
    match v.as_slice() {
        Some(s) => s.iter().map(|&p| p.to_u8()).collect(),
        None => v.iter().map(|&p| p.to_u8()).collect(), // logical (row-major) order for any strides
    }
}

/// H x W x C in cv2's channel order: 1 = gray, 3 = BGR, 4 = BGRA (alpha ignored).
fn gray_from_3d<T: Sample>(v: ArrayView3<'_, T>) -> Vec<u8> {
    let (h, w, c) = v.dim();
    let mut out = Vec::with_capacity(h * w);
    for row in v.outer_iter() {
        for px in row.outer_iter() {
            out.push(if c == 1 { px[0].to_u8() } else { luma_bt601(px[2].to_u8(), px[1].to_u8(), px[0].to_u8()) });
        }
    }
    out
}

/// Type name of a Python object, for messages.
fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into())
}

/// Any accepted image (uint8 or uint16; gray, BGR or BGRA; any strides) as a
/// dense 8-bit gray plane. `what` names the argument in messages.
/// `allow_bool` is for masks: uint8 or bool, 2-D only.
fn to_plane(obj: &Bound<'_, PyAny>, what: &str, allow_bool: bool) -> PyResult<Plane<u8>> {
    let py = obj.py();
    let arr = obj
        .cast::<PyUntypedArray>()
        .map_err(|_| PyTypeError::new_err(format!("{what} must be a numpy.ndarray, got {}", type_name(obj))))?;
    let dt = arr.dtype();
    let (is_u8, is_u16, is_bool) = (
        dt.is_equiv_to(&numpy::dtype::<u8>(py)),
        dt.is_equiv_to(&numpy::dtype::<u16>(py)),
        dt.is_equiv_to(&numpy::dtype::<bool>(py)),
    );
    // images: uint8 or uint16; masks: uint8 or bool
    if !(is_u8 || (is_u16 && !allow_bool) || (is_bool && allow_bool)) {
        let allowed = if allow_bool { "uint8 or bool" } else { "uint8 or uint16" };
        return Err(PyTypeError::new_err(format!("{what} must have dtype {allowed}, got {dt}")));
    }
    let shape = arr.shape().to_vec();
    let channels = match (shape.len(), allow_bool) {
        (2, _) => 1,
        (3, false) if matches!(shape[2], 1 | 3 | 4) => shape[2],
        (3, false) => {
            return Err(PyValueError::new_err(format!(
                "{what} has shape {shape:?}: a 3-D image needs 1, 3 (BGR) or 4 (BGRA) channels"
            )));
        }
        (n, false) => {
            return Err(PyValueError::new_err(format!(
                "{what} must have 2 dimensions (H x W) or 3 (H x W x channels), got {n} (shape {shape:?})"
            )));
        }
        (n, true) => {
            return Err(PyValueError::new_err(format!(
                "{what} must have 2 dimensions (H x W), got {n} (shape {shape:?})"
            )));
        }
    };
    let side = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
    let (w, h) = (side(shape[1]), side(shape[0]));
    if w == 0 || h == 0 {
        return Err(PyValueError::new_err(format!("{what} is empty (shape {shape:?})")));
    }
    check_size(w, h).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    let data = if shape.len() == 2 {
        if is_u8 {
            gray_from_2d(obj.extract::<PyReadonlyArray2<'_, u8>>()?.as_array())
        } else if is_u16 {
            gray_from_2d(obj.extract::<PyReadonlyArray2<'_, u16>>()?.as_array())
        } else {
            gray_from_2d(obj.extract::<PyReadonlyArray2<'_, bool>>()?.as_array())
        }
    } else if is_u8 {
        gray_from_3d(obj.extract::<PyReadonlyArray3<'_, u8>>()?.as_array())
    } else {
        gray_from_3d(obj.extract::<PyReadonlyArray3<'_, u16>>()?.as_array())
    };
    debug_assert!(channels >= 1 && data.len() == w as usize * h as usize);
    Plane::from_vec(w, h, data).map_err(to_py)
}

fn mask_plane(mask: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Plane<u8>>> {
    match mask {
        Some(m) if !m.is_none() => to_plane(m, "mask", true).map(Some),
        _ => Ok(None),
    }
}

// ---------------------------------------------------------------- keypoints

/// Columns of the keypoint array: OpenCV's cv2.KeyPoint fields in order.
const KP_COLS: usize = 7;

fn keypoints_array<'py>(py: Python<'py>, kps: &[KeyPoint]) -> Bound<'py, PyArray2<f32>> {
    let mut data = Vec::with_capacity(kps.len() * KP_COLS);
    for k in kps {
        data.extend_from_slice(&[k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave as f32, k.class_id as f32]);
    }
    Array2::from_shape_vec((kps.len(), KP_COLS), data).expect("N x 7 elements").into_pyarray(py)
}

fn descriptors_array<'py>(py: Python<'py>, desc: &[Descriptor]) -> Bound<'py, PyArray2<u8>> {
    Array2::from_shape_vec((desc.len(), 32), desc.as_flattened().to_vec()).expect("N x 32 bytes").into_pyarray(py)
}

/// An N x 7 float32 array back into keypoints; octave and class_id must be integers.
fn keypoints_from(arr: &Bound<'_, PyAny>) -> PyResult<Vec<KeyPoint>> {
    let a: PyReadonlyArray2<'_, f32> = arr
        .extract()
        .map_err(|_| PyTypeError::new_err("keypoints must be a list of cv2.KeyPoint or an N x 7 float32 array"))?;
    let v = a.as_array();
    if v.ncols() != KP_COLS {
        return Err(PyValueError::new_err(format!("keypoints must have {KP_COLS} columns, got shape {:?}", v.shape())));
    }
    let int = |x: f32, i: usize, what: &str| -> PyResult<i32> {
        if x.fract() == 0.0 && x.abs() < 1e9 {
            Ok(x as i32)
        } else {
            Err(PyValueError::new_err(format!("keypoint {i}: {what} {x} is not an integer")))
        }
    };
    v.outer_iter()
        .enumerate()
        .map(|(i, r)| {
            Ok(KeyPoint {
                pt: [r[0], r[1]].into(),
                size: r[2],
                angle: r[3],
                response: r[4],
                octave: int(r[5], i, "octave")?,
                class_id: int(r[6], i, "class_id")?,
            })
        })
        .collect()
}

/// An N x 32 uint8 array as descriptors.
fn descriptors_from(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Descriptor>> {
    let arr = obj.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!("{what} must be a numpy.ndarray (N x 32 uint8), got {}", type_name(obj)))
    })?;
    if !arr.dtype().is_equiv_to(&numpy::dtype::<u8>(obj.py())) {
        return Err(PyTypeError::new_err(format!("{what} must have dtype uint8, got {}", arr.dtype())));
    }
    let shape = arr.shape().to_vec();
    let v2 = match shape.as_slice() {
        [_, 32] => obj.extract::<PyReadonlyArray2<'_, u8>>()?,
        [32] => {
            // one descriptor: view it as 1 x 32
            let r = obj.call_method1("reshape", (1, 32))?;
            return descriptors_from(&r, what);
        }
        _ => {
            return Err(PyValueError::new_err(format!(
                "{what} must have shape (N, 32) (256-bit descriptors), got {shape:?}"
            )));
        }
    };
    Ok(v2.as_array().outer_iter().map(|r| std::array::from_fn(|k| r[k])).collect())
}

// ---------------------------------------------------------------- config

/// A Python keyword value as JSON, for Config's serde definition.
fn json_value(v: &Bound<'_, PyAny>) -> Option<serde_json::Value> {
    if let Ok(b) = v.extract::<bool>() {
        return Some(b.into());
    }
    if !v.is_instance_of::<PyFloat>() {
        if let Ok(i) = v.extract::<i64>() {
            return Some(i.into());
        }
        if let Ok(u) = v.extract::<u64>() {
            return Some(u.into());
        }
    }
    if v.is_instance_of::<PyString>() {
        return v.extract::<String>().ok().map(Into::into);
    }
    v.extract::<f64>().ok().map(|f| serde_json::Number::from_f64(f).map_or(serde_json::Value::Null, Into::into))
}

/// Config from keywords: every field of [`Config`] by its name; the others
/// keep their defaults. An unknown name is a TypeError (as for any Python
/// call), a bad value a ValueError naming the field.
fn config_from(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Config> {
    let serde_json::Value::Object(mut fields) = serde_json::to_value(Config::default()).expect("Config serialises")
    else {
        unreachable!("Config is a struct")
    };
    for (k, v) in kwargs.into_iter().flat_map(|d| d.iter()) {
        let key: String = k.extract()?;
        if !fields.contains_key(&key) {
            let names: Vec<&str> = fields.keys().map(String::as_str).collect();
            return Err(PyTypeError::new_err(format!(
                "Detector() got an unexpected keyword argument '{key}' (config fields: {})",
                names.join(", ")
            )));
        }
        let bad = |why: String| PyValueError::new_err(format!("invalid config: `{key}` {why}"));
        let value = match json_value(&v) {
            Some(serde_json::Value::Null) => {
                return Err(bad(format!("must be a finite number, got {}", v.repr()?)));
            }
            Some(x) => x,
            None => return Err(bad(format!("has an unsupported type {}", type_name(&v)))),
        };
        // this field alone, so that a type error is reported against its name
        let one = serde_json::Value::Object([(key.clone(), value.clone())].into_iter().collect());
        serde_json::from_value::<Config>(one)
            .map_err(|e| bad(format!("{e} (got {})", v.repr().map(|r| r.to_string()).unwrap_or_default())))?;
        fields.insert(key, value);
    }
    let cfg: Config =
        serde_json::from_value(serde_json::Value::Object(fields)).map_err(|e| PyValueError::new_err(e.to_string()))?;
    cfg.validate().map_err(to_py)?;
    Ok(cfg)
}

fn config_dict<'py>(py: Python<'py>, cfg: &Config) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let serde_json::Value::Object(m) = serde_json::to_value(cfg).expect("Config serialises") else {
        unreachable!("Config is a struct")
    };
    for (k, v) in m {
        match v {
            serde_json::Value::Bool(b) => d.set_item(k, b)?,
            serde_json::Value::Number(n) if n.is_u64() => d.set_item(k, n.as_u64())?,
            serde_json::Value::Number(n) if n.is_i64() => d.set_item(k, n.as_i64())?,
            serde_json::Value::Number(n) => d.set_item(k, n.as_f64())?,
            serde_json::Value::String(s) => d.set_item(k, s)?,
            other => d.set_item(k, other.to_string())?,
        }
    }
    Ok(d)
}

// ---------------------------------------------------------------- Detector

/// Keypoints (N x 7 float32) and descriptors (N x 32 uint8).
type Features<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray2<u8>>);

/// The native detector; `lfast.Detector` wraps it with OpenCV's types.
#[pyclass(name = "Detector", module = "lfast._lfast", frozen)]
struct PyDetector {
    det: Detector,
    /// Descriptors of given keypoints (`compute`): the CPU reference, which
    /// gives the GPU's results bit for bit.
    cpu: CpuDetector,
}

#[pymethods]
impl PyDetector {
    #[new]
    #[pyo3(signature = (backend = "auto", **config))]
    fn new(py: Python<'_>, backend: &str, config: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let backend: Backend = backend.parse().map_err(to_py)?;
        let cfg = config_from(config)?;
        py.detach(|| -> lfast::Result<Self> {
            Ok(Self { det: Detector::new(cfg.clone(), backend)?, cpu: CpuDetector::new(cfg)? })
        })
        .map_err(to_py)
    }

    /// `"gpu"` or `"cpu"`: where the next frame runs.
    #[getter]
    fn backend(&self) -> &'static str {
        self.det.backend_name()
    }

    /// The GPU adapter's name, or None on the CPU.
    #[getter]
    fn adapter(&self) -> Option<String> {
        self.det.adapter_name()
    }

    /// The configuration as a dict of every field.
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        config_dict(py, self.det.config())
    }

    #[pyo3(signature = (image, mask = None))]
    fn detect<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        mask: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let img = to_plane(image, "image", false)?;
        let mask = mask_plane(mask)?;
        let kps = py.detach(|| self.det.detect(img.view(), mask.as_ref().map(Plane::view))).map_err(to_py)?;
        Ok(keypoints_array(py, &kps))
    }

    #[pyo3(signature = (image, mask = None))]
    fn detect_and_compute<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        mask: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Features<'py>> {
        let img = to_plane(image, "image", false)?;
        let mask = mask_plane(mask)?;
        let (kps, desc) =
            py.detach(|| self.det.detect_and_compute(img.view(), mask.as_ref().map(Plane::view))).map_err(to_py)?;
        Ok((keypoints_array(py, &kps), descriptors_array(py, &desc)))
    }

    fn compute<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        keypoints: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<u8>>> {
        let img = to_plane(image, "image", false)?;
        let kps = keypoints_from(keypoints)?;
        let desc = py.detach(|| self.cpu.compute(img.view(), &kps)).map_err(to_py)?;
        Ok(descriptors_array(py, &desc))
    }

    fn edges<'py>(&self, py: Python<'py>, image: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        let img = to_plane(image, "image", false)?;
        let e = py.detach(|| self.det.edge_image(img.view())).map_err(to_py)?;
        let (w, h) = (e.width as usize, e.height as usize);
        Ok(Array2::from_shape_vec((h, w), e.data).expect("H x W pixels").into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        let c = self.det.config();
        format!(
            "lfast.Detector(backend='{}', mode='{}', n_features={}, n_levels={})",
            self.det.backend_name(),
            if c.mode == lfast::Mode::Paper { "paper" } else { "branch" },
            c.n_features,
            c.n_levels
        )
    }
}

// ---------------------------------------------------------------- free functions

/// Default value of every Config field.
#[pyfunction]
fn default_config(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    config_dict(py, &Config::default())
}

/// Matches as an M x 3 int32 array: query index, train index, Hamming distance.
#[pyfunction]
#[pyo3(signature = (query, train, cross_check = true, ratio = None, max_distance = None))]
fn match_arrays<'py>(
    py: Python<'py>,
    query: &Bound<'py, PyAny>,
    train: &Bound<'py, PyAny>,
    cross_check: bool,
    ratio: Option<f64>,
    max_distance: Option<i64>,
) -> PyResult<Bound<'py, PyArray2<i32>>> {
    let q = descriptors_from(query, "query")?;
    let t = descriptors_from(train, "train")?;
    let max_distance = match max_distance {
        None => 256,
        Some(d) if (0..=256).contains(&d) => d as u32,
        Some(d) => {
            return Err(PyValueError::new_err(format!("max_distance must be in 0..=256, got {d}")));
        }
    };
    let opts = MatchOptions { cross_check, ratio: ratio.map(|r| r as f32), max_distance };
    let m = py.detach(|| match_descriptors(&q, &t, &opts)).map_err(to_py)?;
    let data: Vec<i32> = m.iter().flat_map(|m| [m.query as i32, m.train as i32, m.distance as i32]).collect();
    Ok(Array2::from_shape_vec((m.len(), 3), data).expect("M x 3").into_pyarray(py))
}

/// Hamming distances: an int for two descriptors, else an N x M uint32 matrix.
#[pyfunction]
fn hamming<'py>(py: Python<'py>, a: &Bound<'py, PyAny>, b: &Bound<'py, PyAny>) -> PyResult<Py<PyAny>> {
    let one = |x: &Bound<'py, PyAny>| x.cast::<PyUntypedArray>().map(|a| a.ndim() == 1).unwrap_or(false);
    let (da, db) = (descriptors_from(a, "a")?, descriptors_from(b, "b")?);
    if one(a) && one(b) {
        return Ok(lfast::hamming(&da[0], &db[0]).into_pyobject(py)?.into_any().unbind());
    }
    let data: Vec<u32> = py.detach(|| da.iter().flat_map(|x| db.iter().map(move |y| lfast::hamming(x, y))).collect());
    Ok(Array2::from_shape_vec((da.len(), db.len()), data).expect("N x M").into_pyarray(py).into_any().unbind())
}

/// Reads an image file as 8-bit gray exactly as `lfast detect` does (SPEC 0).
#[pyfunction]
fn imread(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray2<u8>>> {
    let p = py.detach(|| lfast::image::load_gray(&path)).map_err(to_py)?;
    let (w, h) = (p.width as usize, p.height as usize);
    Ok(Array2::from_shape_vec((h, w), p.data).expect("H x W").into_pyarray(py))
}

/// The frames of a recording (MCAP file, video), as `lfast detect` reads
/// them: an iterator of `(time_ns, gray uint8 H x W array)`.
#[pyclass(name = "Frames", module = "lfast._lfast")]
struct PyFrames {
    rec: std::sync::Mutex<Option<lfast::recording::Recording>>,
}

#[pymethods]
impl PyFrames {
    #[new]
    #[pyo3(signature = (path, topic = None))]
    fn new(py: Python<'_>, path: PathBuf, topic: Option<String>) -> PyResult<Self> {
        let sel = lfast::recording::Selection { topic, ..Default::default() };
        let rec = py.detach(|| lfast::recording::Recording::open(&path, &sel)).map_err(to_py)?;
        Ok(PyFrames { rec: std::sync::Mutex::new(Some(rec)) })
    }

    /// The MCAP topic read (None for video).
    #[getter]
    fn topic(&self) -> Option<String> {
        let g = self.rec.lock().unwrap_or_else(|e| e.into_inner());
        g.as_ref().and_then(|r| r.topic().map(str::to_string))
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Option<(u64, Bound<'py, PyArray2<u8>>)>> {
        let next = py.detach(|| {
            let mut g = self.rec.lock().unwrap_or_else(|e| e.into_inner());
            let Some(rec) = g.as_mut() else { return Ok(None) };
            let r = match rec.next() {
                None => Ok(None),
                Some(Err(e)) => Err(e),
                Some(Ok(p)) => p.decode().map(|d| Some((p.time_ns, d.image))),
            };
            if !matches!(r, Ok(Some(_))) {
                // ended, or damaged here: nothing more comes
                *g = None;
            }
            r
        });
        match next.map_err(to_py)? {
            None => Ok(None),
            Some((t, p)) => {
                let (w, h) = (p.width as usize, p.height as usize);
                Ok(Some((t, Array2::from_shape_vec((h, w), p.data).expect("H x W").into_pyarray(py))))
            }
        }
    }
}

/// Output suffix of each format, as `lfast detect` names its files.
fn suffixes(format: &str) -> Option<&'static [&'static str]> {
    Some(match format {
        "json" => &[".json"],
        "csv" => &[".csv"],
        "npy" => &[".keypoints.npy", ".descriptors.npy"],
        "yaml" => &[".yaml"],
        _ => return None,
    })
}

/// Writes the files `lfast detect --format ...` writes for one image.
#[pyfunction]
#[pyo3(signature = (base, image, width, height, keypoints, descriptors, formats = vec!["json".to_string()]))]
#[allow(clippy::too_many_arguments)]
fn write_features(
    py: Python<'_>,
    base: PathBuf,
    image: PathBuf,
    width: u32,
    height: u32,
    keypoints: &Bound<'_, PyAny>,
    descriptors: &Bound<'_, PyAny>,
    formats: Vec<String>,
) -> PyResult<Vec<PathBuf>> {
    let kps = keypoints_from(keypoints)?;
    let desc = descriptors_from(descriptors, "descriptors")?;
    if kps.len() != desc.len() {
        return Err(PyValueError::new_err(format!("{} keypoints but {} descriptors", kps.len(), desc.len())));
    }
    let mut seen: Vec<&str> = Vec::new();
    for f in &formats {
        if suffixes(f).is_none() {
            return Err(PyValueError::new_err(format!("unknown format `{f}` (expected json, csv, npy or yaml)")));
        }
        if !seen.contains(&f.as_str()) {
            seen.push(f);
        }
    }
    py.detach(|| -> lfast::Result<Vec<PathBuf>> {
        let with = |s: &str| {
            let mut p = base.clone().into_os_string();
            p.push(s);
            PathBuf::from(p)
        };
        if let Some(dir) = base.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| lfast::Error::Io { path: dir.to_path_buf(), source })?;
        }
        let mut written = Vec::new();
        let mut put = |suffix: &str, bytes: &[u8]| -> lfast::Result<()> {
            let p = with(suffix);
            lfast::io::write_atomic(&p, bytes)?;
            written.push(p);
            Ok(())
        };
        for f in seen {
            match f {
                "json" => put(".json", lfast::io::features_json(&image, width, height, &kps, &desc).as_bytes())?,
                "csv" => put(".csv", lfast::io::features_csv(&kps, &desc).as_bytes())?,
                "npy" => {
                    put(".keypoints.npy", &lfast::io::keypoints_npy(&kps))?;
                    put(".descriptors.npy", &lfast::io::descriptors_npy(&desc))?;
                }
                _ => put(".yaml", lfast::io::features_yaml(&kps, &desc).as_bytes())?,
            }
        }
        Ok(written)
    })
    .map_err(to_py)
}

/// Names of the files `write_features(base, ...)` writes for `formats`.
#[pyfunction]
#[pyo3(signature = (base, formats = vec!["json".to_string()]))]
fn output_paths(base: &str, formats: Vec<String>) -> PyResult<Vec<String>> {
    let mut out = Vec::new();
    for f in &formats {
        let s = suffixes(f)
            .ok_or_else(|| PyValueError::new_err(format!("unknown format `{f}` (expected json, csv, npy or yaml)")))?;
        for x in s {
            let p = format!("{base}{x}");
            if !out.contains(&p) {
                out.push(p);
            }
        }
    }
    Ok(out)
}

#[pymodule]
fn _lfast(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyDetector>()?;
    m.add_class::<PyFrames>()?;
    m.add("GpuError", m.py().get_type::<GpuError>())?;
    m.add_function(wrap_pyfunction!(default_config, m)?)?;
    m.add_function(wrap_pyfunction!(match_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(hamming, m)?)?;
    m.add_function(wrap_pyfunction!(imread, m)?)?;
    m.add_function(wrap_pyfunction!(write_features, m)?)?;
    m.add_function(wrap_pyfunction!(output_paths, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
