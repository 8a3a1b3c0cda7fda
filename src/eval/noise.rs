//! Suite 1 (paper Table 1): seeded 5% salt-and-pepper noise on the standard
//! images; PSNR and SNR against the clean image of the noisy image, the
//! Gaussian (5x5, sigma 0.8) and the flagged median (SPEC 1).

use super::format::{Csv, csv_f, num, table};
use super::metrics::{psnr, salt_and_pepper, seed_for, snr};
use super::output::write_section;
use super::plot::{Bars, Panel, figure};
use super::{NamedImage, Options, Result, Suite, load_standard, mean};
use crate::config::{Config, DELTA_DEN};
use crate::cpu::blur::{gaussian_blur, gaussian_kernel_q8};
use crate::cpu::median::median;
use crate::image::Plane;
use serde::{Deserialize, Serialize};

/// Fraction of pixels hit by the noise.
pub const NOISE_FRACTION: f64 = 0.05;
/// Gaussian of the comparison: sigma and kernel size.
pub const GAUSS_SIGMA: f64 = 0.8;
/// Gaussian kernel size.
pub const GAUSS_KSIZE: usize = 5;

/// A standard image with its seeded noisy copy.
#[derive(Clone, Debug)]
pub struct Noisy {
    /// The clean image.
    pub clean: NamedImage,
    /// The same with salt-and-pepper noise.
    pub noisy: Plane<u8>,
}

/// The noisy copies of every standard image of `opts`.
pub fn noisy_images(opts: &Options) -> Result<Vec<Noisy>> {
    Ok(load_standard(&opts.standard)?
        .into_iter()
        .map(|clean| {
            let noisy = salt_and_pepper(&clean.image, NOISE_FRACTION, seed_for(opts.seed, &clean.name));
            Noisy { clean, noisy }
        })
        .collect())
}

/// The Gaussian of the comparison.
pub fn gaussian(img: &Plane<u8>) -> Plane<u8> {
    gaussian_blur(img, &gaussian_kernel_q8(GAUSS_KSIZE, GAUSS_SIGMA))
}

/// The flagged median with the default delta.
pub fn flagged_median(img: &Plane<u8>) -> Plane<u8> {
    median(img, Config::default().delta_num(), DELTA_DEN)
}

/// One image's numbers.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct NoiseRow {
    /// Image name.
    pub image: String,
    /// Pixels the noise changed.
    pub changed: usize,
    /// PSNR / SNR of the noisy image.
    pub noisy_psnr: f64,
    /// SNR of the noisy image.
    pub noisy_snr: f64,
    /// PSNR of the Gaussian.
    pub gauss_psnr: f64,
    /// SNR of the Gaussian.
    pub gauss_snr: f64,
    /// PSNR of the flagged median.
    pub median_psnr: f64,
    /// SNR of the flagged median.
    pub median_snr: f64,
}

/// What the suite leaves for the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct NoiseSummary {
    /// Seed of the noise.
    pub seed: u64,
    /// Per image.
    pub rows: Vec<NoiseRow>,
    /// Mean PSNR of the Gaussian.
    pub mean_gauss_psnr: f64,
    /// Mean PSNR of the flagged median.
    pub mean_median_psnr: f64,
}

/// The numbers of one image.
pub fn evaluate(n: &Noisy) -> Result<NoiseRow> {
    let (c, x) = (&n.clean.image, &n.noisy);
    let (g, m) = (gaussian(x), flagged_median(x));
    Ok(NoiseRow {
        image: n.clean.name.clone(),
        changed: c.data.iter().zip(&x.data).filter(|(a, b)| a != b).count(),
        noisy_psnr: psnr(c, x)?,
        noisy_snr: snr(c, x)?,
        gauss_psnr: psnr(c, &g)?,
        gauss_snr: snr(c, &g)?,
        median_psnr: psnr(c, &m)?,
        median_snr: snr(c, &m)?,
    })
}

/// Runs the suite: `noise.csv`, `noise.png`, the section.
pub fn run(opts: &Options) -> Result<()> {
    let images = noisy_images(opts)?;
    let rows = images.iter().map(evaluate).collect::<Result<Vec<_>>>()?;
    let mut csv = Csv::new(&[
        "image",
        "width",
        "height",
        "noise_fraction",
        "seed",
        "changed_pixels",
        "noisy_psnr_db",
        "noisy_snr_db",
        "gaussian_psnr_db",
        "gaussian_snr_db",
        "flagged_median_psnr_db",
        "flagged_median_snr_db",
    ]);
    for (r, n) in rows.iter().zip(&images) {
        csv.row(vec![
            r.image.clone(),
            n.clean.image.width.to_string(),
            n.clean.image.height.to_string(),
            NOISE_FRACTION.to_string(),
            opts.seed.to_string(),
            r.changed.to_string(),
            csv_f(r.noisy_psnr),
            csv_f(r.noisy_snr),
            csv_f(r.gauss_psnr),
            csv_f(r.gauss_snr),
            csv_f(r.median_psnr),
            csv_f(r.median_snr),
        ]);
    }
    csv.write(&opts.out.join("noise.csv"))?;

    let cats: Vec<String> = rows.iter().map(|r| r.image.clone()).collect();
    let bars = |f: &dyn Fn(&NoiseRow) -> [f64; 3]| -> Vec<Bars> {
        ["noisy input", "Gaussian 5x5 σ0.8", "flagged median"]
            .iter()
            .enumerate()
            .map(|(i, name)| Bars {
                name: name.to_string(),
                colour: [7, 3, 0][i],
                values: rows.iter().map(|r| f(r)[i]).collect(),
            })
            .collect()
    };
    figure(
        &opts.out.join("noise.png"),
        (1200, 480),
        (1, 2),
        &[
            Panel::Bar {
                title: "PSNR against the clean image".into(),
                y_desc: "PSNR (dB)".into(),
                categories: cats.clone(),
                bars: bars(&|r| [r.noisy_psnr, r.gauss_psnr, r.median_psnr]),
            },
            Panel::Bar {
                title: "SNR against the clean image".into(),
                y_desc: "SNR (dB)".into(),
                categories: cats,
                bars: bars(&|r| [r.noisy_snr, r.gauss_snr, r.median_snr]),
            },
        ],
    )?;

    let mean_gauss_psnr = mean(rows.iter().map(|r| r.gauss_psnr));
    let mean_median_psnr = mean(rows.iter().map(|r| r.median_psnr));
    let wins = rows.iter().filter(|r| r.median_psnr > r.gauss_psnr && r.median_snr > r.gauss_snr).count();
    let trow: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.image.clone(),
                r.changed.to_string(),
                num(r.noisy_psnr, 2),
                num(r.gauss_psnr, 2),
                num(r.median_psnr, 2),
                num(r.noisy_snr, 2),
                num(r.gauss_snr, 2),
                num(r.median_snr, 2),
            ]
        })
        .collect();
    let md = format!(
        "## 1. Noise (paper Table 1)\n\n\
         {} standard image(s) from `{}` with {}% salt-and-pepper noise (seed {}); dB against the clean image. \
         Files: `noise.csv`, `noise.png`.\n\n{}\n\
         The flagged median beats the Gaussian on both PSNR and SNR on **{wins} of {}** images \
         (mean PSNR {} dB vs {} dB).\n\n\
         Paper (Table 1): the improved (flagged) median gives a higher PSNR and SNR than the Gaussian on each \
         of the four images. The published per-image values were not available to this evaluation, so only \
         the direction can be compared: {}.\n\n![noise](noise.png)\n",
        rows.len(),
        opts.standard.display(),
        NOISE_FRACTION * 100.0,
        opts.seed,
        table(
            &[
                "image",
                "noisy pixels",
                "PSNR noisy",
                "PSNR Gaussian",
                "PSNR flagged median",
                "SNR noisy",
                "SNR Gaussian",
                "SNR flagged median"
            ],
            &trow
        ),
        rows.len(),
        num(mean_median_psnr, 2),
        num(mean_gauss_psnr, 2),
        if wins == rows.len() { "reproduced" } else { "not reproduced on every image" },
    );
    let summary = NoiseSummary { seed: opts.seed, rows, mean_gauss_psnr, mean_median_psnr };
    write_section(&opts.out, Suite::Noise, &md, &summary)
}
