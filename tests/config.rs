//! `Config`: SPEC defaults, TOML round trip, partial files, unknown fields,
//! validation of every range, and the errors of `Config::load`.

use lfast::{Config, DescriptorKind, Error, Mode};

#[test]
fn defaults_are_the_spec_values() {
    let c = Config::default();
    assert_eq!(c.delta, 0.1);
    assert_eq!(c.alpha_pct, 35);
    // mode, support, snap_radius and reject_edges as the evaluation chose them (docs/evaluation.md)
    assert_eq!(c.mode, Mode::Paper);
    assert_eq!(c.support, 3);
    assert_eq!(c.snap_radius, 2);
    assert!(c.reject_edges);
    assert_eq!(c.straight_tol, 1);
    assert_eq!(c.border, 16);
    assert_eq!(c.nms_radius, 4);
    assert_eq!(c.n_levels, 8);
    assert_eq!(c.scale_factor, 1.2);
    assert_eq!(c.n_features, 0);
    assert!(!c.distribution);
    assert_eq!(c.orientation_bins, 180); // finer than SPEC 11's 30 (docs/quality.md); Config::paper() keeps 30
    c.validate().expect("the defaults are valid");
    // SPEC 1: delta = 1/10 as a rational
    assert_eq!(c.delta_num() as u64 * 10, lfast::config::DELTA_DEN as u64);
}

#[test]
fn toml_round_trip() {
    let defaults = Config::default();
    assert_eq!(Config::from_toml_str(&defaults.to_toml_string()).unwrap(), defaults);

    // every field away from its default
    let c = Config {
        delta: 0.25,
        alpha_pct: 20,
        mode: Mode::Branch,
        support: 5,
        straight_tol: 2,
        border: 20,
        nms_radius: 1,
        n_levels: 4,
        scale_factor: 1.5,
        n_features: 1000,
        distribution: true,
        orientation_bins: 0,
        descriptor: DescriptorKind::Opencv,
        snap_radius: 0,
        reject_edges: false,
        fill_fast_ini: 25,
        fill_fast_min: 9,
    };
    c.validate().unwrap();
    let text = c.to_toml_string();
    assert!(text.contains("mode = \"branch\""), "{text}");
    assert_eq!(Config::from_toml_str(&text).unwrap(), c, "{text}");

    // through a file too
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cfg.toml");
    std::fs::write(&p, &text).unwrap();
    assert_eq!(Config::load(&p).unwrap(), c);
}

#[test]
fn partial_toml_takes_defaults() {
    let c = Config::from_toml_str("mode = \"paper\"\nn_features = 500\n").unwrap();
    assert_eq!(c, Config { mode: Mode::Paper, n_features: 500, ..Config::default() });
    assert_eq!(Config::from_toml_str("").unwrap(), Config::default());
    assert_eq!(Config::from_toml_str("# only a comment\n").unwrap(), Config::default());
    // the mode is written in lower case
    assert!(Config::from_toml_str("mode = \"Paper\"").is_err());
}

#[test]
fn unknown_field_is_an_error() {
    let e = Config::from_toml_str("delta = 0.1\nn_feature = 10\n").unwrap_err();
    assert!(matches!(e, Error::ConfigParse { .. }), "{e:?}");
    assert!(e.to_string().contains("n_feature"), "{e}");
}

#[test]
fn wrong_type_is_an_error() {
    for text in ["n_levels = \"8\"", "n_levels = -1", "distribution = 1", "mode = 3", "delta = [0.1]"] {
        let e = Config::from_toml_str(text).unwrap_err();
        assert!(matches!(e, Error::ConfigParse { .. }), "{text}: {e:?}");
    }
}

/// Every invalid value names its field, both in the variant and in the message;
/// validate() and from_toml_str agree.
#[test]
fn invalid_values_name_their_field() {
    let d = Config::default;
    let cases: Vec<(&str, Config, &str)> = vec![
        ("delta", Config { delta: 0.0, ..d() }, "delta = 0.0"),
        ("delta", Config { delta: -0.1, ..d() }, "delta = -0.1"),
        ("delta", Config { delta: f64::NAN, ..d() }, "delta = nan"),
        ("delta", Config { delta: f64::INFINITY, ..d() }, "delta = inf"),
        ("delta", Config { delta: f64::NEG_INFINITY, ..d() }, "delta = -inf"),
        ("delta", Config { delta: 1e-9, ..d() }, "delta = 1e-9"),
        ("delta", Config { delta: 1000.0, ..d() }, "delta = 1000.0"),
        ("alpha_pct", Config { alpha_pct: 100, ..d() }, "alpha_pct = 100"),
        ("alpha_pct", Config { alpha_pct: 250, ..d() }, "alpha_pct = 250"),
        ("scale_factor", Config { scale_factor: 1.0, ..d() }, "scale_factor = 1.0"),
        ("scale_factor", Config { scale_factor: 0.5, ..d() }, "scale_factor = 0.5"),
        ("scale_factor", Config { scale_factor: f64::NAN, ..d() }, "scale_factor = nan"),
        ("scale_factor", Config { scale_factor: f64::INFINITY, ..d() }, "scale_factor = inf"),
        ("scale_factor", Config { scale_factor: 5.0, ..d() }, "scale_factor = 5.0"),
        ("n_levels", Config { n_levels: 0, ..d() }, "n_levels = 0"),
        ("n_levels", Config { n_levels: 33, ..d() }, "n_levels = 33"),
        ("border", Config { border: 6, ..d() }, "border = 6"),
        ("border", Config { border: 0, ..d() }, "border = 0"),
        ("support", Config { support: 0, ..d() }, "support = 0"),
        ("support", Config { support: 9, ..d() }, "support = 9"),
        ("straight_tol", Config { straight_tol: 8, ..d() }, "straight_tol = 8"),
        ("nms_radius", Config { nms_radius: 33, ..d() }, "nms_radius = 33"),
        ("orientation_bins", Config { orientation_bins: 361, ..d() }, "orientation_bins = 361"),
        ("snap_radius", Config { snap_radius: 17, ..d() }, "snap_radius = 17"),
    ];
    for (field, cfg, toml) in cases {
        let e = cfg.validate().unwrap_err();
        match &e {
            Error::InvalidConfig { field: f, .. } => assert_eq!(*f, field, "{toml}: {e}"),
            other => panic!("{toml}: expected InvalidConfig, got {other:?}"),
        }
        assert!(e.to_string().contains(field), "{toml}: message `{e}` does not name {field}");

        let e = Config::from_toml_str(toml).unwrap_err();
        assert!(matches!(&e, Error::InvalidConfig { field: f, .. } if *f == field), "{toml}: {e:?}");

        let e = lfast::cpu::CpuDetector::new(cfg).unwrap_err();
        assert!(matches!(&e, Error::InvalidConfig { field: f, .. } if *f == field), "{toml}: {e:?}");
    }
}

#[test]
fn boundary_values_are_valid() {
    let d = Config::default;
    for cfg in [
        Config { alpha_pct: 0, ..d() },
        Config { alpha_pct: 99, ..d() },
        Config { support: 1, ..d() },
        Config { support: 8, ..d() },
        Config { straight_tol: 0, ..d() },
        Config { straight_tol: 7, ..d() },
        Config { border: 7, ..d() },
        Config { nms_radius: 0, ..d() },
        Config { n_levels: 1, ..d() },
        Config { n_levels: 32, ..d() },
        Config { scale_factor: 1.0001, ..d() },
        Config { scale_factor: 4.0, ..d() },
        Config { orientation_bins: 0, ..d() },
        Config { orientation_bins: 360, ..d() },
        Config { delta: 0.0001, ..d() },
    ] {
        cfg.validate().unwrap_or_else(|e| panic!("{cfg:?}: {e}"));
    }
}

#[test]
fn load_missing_file_is_io_error_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("no_such_config.toml");
    let e = Config::load(&p).unwrap_err();
    match &e {
        Error::Io { path, source } => {
            assert_eq!(path, &p);
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("expected Io, got {other:?}"),
    }
    assert!(e.to_string().contains("no_such_config.toml"), "{e}");
}

#[test]
fn load_malformed_file_is_parse_error_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("broken.toml");
    std::fs::write(&p, "delta = = 0.1\n[[[\n").unwrap();
    let e = Config::load(&p).unwrap_err();
    match &e {
        Error::ConfigParse { path, message } => {
            assert_eq!(path, &p);
            assert!(!message.is_empty());
        }
        other => panic!("expected ConfigParse, got {other:?}"),
    }
    assert!(e.to_string().contains("broken.toml"), "{e}");
}

#[test]
fn load_invalid_value_is_invalid_config() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(&p, "scale_factor = 1.0\n").unwrap();
    let e = Config::load(&p).unwrap_err();
    assert!(matches!(e, Error::InvalidConfig { field: "scale_factor", .. }), "{e:?}");
}

#[test]
fn level_sizes_follow_spec_10() {
    let c = Config::default();
    let sizes = c.level_sizes(1241, 376);
    assert_eq!(sizes.len(), 8);
    assert_eq!(sizes[0], (1241, 376));
    for (l, &(w, h)) in sizes.iter().enumerate() {
        let s = 1.2f64.powi(l as i32);
        assert_eq!(w, (1241.0 / s).round() as u32, "level {l}");
        assert_eq!(h, (376.0 / s).round() as u32, "level {l}");
    }
    assert_eq!(Config { n_levels: 1, ..c }.level_sizes(10, 10), vec![(10, 10)]);
}
