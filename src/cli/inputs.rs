//! Turning command-line inputs (files, directories, globs, list files) into
//! a sorted list of images with their output names, and sharding it.

use super::CliError;
use std::collections::{HashMap, HashSet};
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// File extensions taken from directories and globs (case-insensitive).
/// Files named one by one are taken whatever their extension.
pub const IMAGE_EXTENSIONS: &[&str] = &["png", "jpg", "jpeg", "tif", "tiff", "bmp", "pgm", "ppm", "pnm", "pbm"];

/// One input image.
#[derive(Clone, Debug)]
pub struct Input {
    /// The file as found.
    pub path: PathBuf,
    /// Output name without extension, relative to the output directory:
    /// the file stem, or for a file found in a directory its path below that
    /// directory without extension.
    pub rel: PathBuf,
    /// Set when the entry cannot be processed for a reason known up front.
    pub problem: Option<Problem>,
}

impl Input {
    /// Whether this entry is a file (to process, or failed as a file), not
    /// an error of the directory walk.
    pub fn is_file(&self) -> bool {
        !matches!(self.problem, Some(Problem::Walk { .. }))
    }
}

/// Why an entry cannot be processed, known before any work starts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Problem {
    /// Not a file: the directory walk could not follow or read this entry.
    /// `kind` names the error in the batch summary (`symbolic link loop`,
    /// `unreadable directory`), `reason` on its error line. The summary counts
    /// these apart from files.
    Walk {
        /// A short name of the error, for the summary.
        kind: &'static str,
        /// The full reason, for the error line.
        reason: String,
    },
    /// A file that cannot be processed: its output name collides with an
    /// earlier input's, or it is a dangling link named like an image.
    File(String),
}

/// `K/N`: this run does shard K (0-based) of N.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, 0..n.
    pub k: usize,
    /// Number of shards, >= 1.
    pub n: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("`{s}` is not K/N with 0 <= K < N (K is 0-based, e.g. 0/4 .. 3/4)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n): (usize, usize) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if n == 0 || k >= n {
            return Err(bad());
        }
        Ok(Shard { k, n })
    }
}

fn is_image(p: &Path) -> bool {
    p.extension().and_then(|e| e.to_str()).is_some_and(|e| IMAGE_EXTENSIONS.iter().any(|x| x.eq_ignore_ascii_case(e)))
}

/// MCAP files and videos: taken from globs (not from directories, which are searched for images).
fn is_recording(p: &Path) -> bool {
    crate::recording::format_of(p).is_some()
}

fn is_hidden(p: &Path) -> bool {
    p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with('.'))
}

fn without_extension(p: &Path) -> PathBuf {
    match (p.parent(), p.file_stem()) {
        (Some(dir), Some(stem)) => dir.join(stem),
        _ => p.to_path_buf(),
    }
}

fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

/// Walks `root` recursively for images in file-name order, following
/// symbolic links, skipping hidden entries and `skip` (the output directory,
/// so outputs are never taken as inputs). A link back to one of its own
/// ancestors (a loop) is not followed but becomes an entry with a
/// [`Problem::Walk`] naming it and the directory it leads back to, so that the
/// batch reports it on one error line and goes on; an unreadable directory
/// likewise. A broken link named like an image is a file that fails
/// ([`Problem::File`]).
fn walk(root: &Path, skip: Option<&Path>, out: &mut Vec<Input>) {
    let skipped = |e: &walkdir::DirEntry| {
        e.depth() > 0
            && (is_hidden(e.path())
                || (e.file_type().is_dir() && skip.is_some_and(|s| e.path().canonicalize().is_ok_and(|c| c == s))))
    };
    let rel = |p: &Path| without_extension(p.strip_prefix(root).unwrap_or(p));
    let entries = walkdir::WalkDir::new(root).follow_links(true).sort_by_file_name().into_iter();
    for r in entries.filter_entry(|e| !skipped(e)) {
        match r {
            Ok(e) if e.file_type().is_file() && is_image(e.path()) => {
                out.push(Input { path: e.path().to_path_buf(), rel: rel(e.path()), problem: None })
            }
            Ok(_) => {}
            Err(err) => {
                let path = err.path().unwrap_or(root).to_path_buf();
                let problem = match (err.loop_ancestor(), err.io_error()) {
                    (Some(ancestor), _) => Problem::Walk {
                        kind: "symbolic link loop",
                        reason: format!("symbolic link loop (leads back to {}), not followed", ancestor.display()),
                    },
                    // a dangling link is an input only when named like one
                    _ if path.is_symlink() && !path.exists() => match is_image(&path) {
                        true => Problem::File(err.io_error().map_or_else(|| err.to_string(), |io| io.to_string())),
                        false => continue,
                    },
                    (None, Some(io)) if path.is_dir() || io.kind() == std::io::ErrorKind::PermissionDenied => {
                        Problem::Walk { kind: "unreadable directory", reason: io.to_string() }
                    }
                    (None, Some(io)) => Problem::Walk { kind: "walk error", reason: io.to_string() },
                    (None, None) => Problem::Walk { kind: "walk error", reason: err.to_string() },
                };
                out.push(Input { rel: rel(&path), path, problem: Some(problem) });
            }
        }
    }
}

fn file_input(p: PathBuf) -> Input {
    let rel = PathBuf::from(p.file_stem().unwrap_or(p.as_os_str()));
    Input { path: p, rel, problem: None }
}

/// Adds the images named by one argument: a directory (recursive), an existing
/// file, a glob pattern, or else a file name taken as is (so that a missing
/// file fails later with its own error line).
fn add(arg: &Path, skip: Option<&Path>, out: &mut Vec<Input>) -> Result<(), CliError> {
    if arg.is_dir() {
        walk(arg, skip, out);
        return Ok(());
    }
    let s = arg.to_string_lossy();
    if !arg.exists() && has_glob_chars(&s) {
        let paths = glob::glob(&s).map_err(|e| CliError::Inputs(format!("bad glob `{s}`: {e}")))?;
        let mut n = 0;
        for p in paths.flatten() {
            n += 1;
            if p.is_dir() {
                walk(&p, skip, out);
            } else if is_image(&p) || is_recording(&p) {
                out.push(file_input(p));
            }
        }
        if n == 0 {
            return Err(CliError::Inputs(format!("no file matches `{s}`")));
        }
        return Ok(());
    }
    out.push(file_input(arg.to_path_buf()));
    Ok(())
}

/// Reads a list file (`-` = standard input): one input per line; blank lines
/// and lines starting with `#` are skipped.
fn read_list(list: &Path) -> Result<Vec<PathBuf>, CliError> {
    let err = |e: std::io::Error| CliError::Inputs(format!("list {}: {e}", list.display()));
    let lines: Vec<String> = if list.as_os_str() == "-" {
        std::io::stdin().lock().lines().collect::<Result<_, _>>().map_err(err)?
    } else {
        let f = std::fs::File::open(list).map_err(err)?;
        std::io::BufReader::new(f).lines().collect::<Result<_, _>>().map_err(err)?
    };
    Ok(lines.iter().map(|l| l.trim()).filter(|l| !l.is_empty() && !l.starts_with('#')).map(PathBuf::from).collect())
}

/// Where the entry `p` itself lives: its directory's canonical path and its
/// name (its target is not resolved).
fn link_location(p: &Path) -> PathBuf {
    match (p.parent().and_then(|d| d.canonicalize().ok()), p.file_name()) {
        (Some(dir), Some(name)) => dir.join(name),
        _ => p.to_path_buf(),
    }
}

/// All inputs, sorted by path; each file once, by its canonical path, under
/// the path it was first found by (arguments in order, directories in
/// file-name order), even when links make it reachable twice. Inputs whose
/// output name collides with an earlier one's get a `problem`. `out_dir` is
/// never walked.
pub fn collect(args: &[PathBuf], list: Option<&Path>, out_dir: &Path) -> Result<Vec<Input>, CliError> {
    let mut named: Vec<PathBuf> = args.to_vec();
    if let Some(l) = list {
        named.extend(read_list(l)?);
    }
    if named.is_empty() {
        return Err(CliError::Inputs("no inputs: name files, directories or globs, or use --from-list".into()));
    }
    let skip = out_dir.canonicalize().ok();
    let mut all = Vec::new();
    for a in &named {
        add(a, skip.as_deref(), &mut all)?;
    }
    if all.is_empty() {
        return Err(CliError::Inputs("no images found in the inputs".into()));
    }
    let (mut files, mut problems) = (HashSet::new(), HashSet::new());
    all.retain(|i| match i.problem {
        None => files.insert(i.path.canonicalize().unwrap_or_else(|_| i.path.clone())),
        // a link by its own location, so that a loop reached twice is named once
        Some(_) => problems.insert(link_location(&i.path)),
    });
    all.sort_by(|a, b| a.path.cmp(&b.path));
    let mut seen: HashMap<PathBuf, PathBuf> = HashMap::new();
    for i in all.iter_mut().filter(|i| i.problem.is_none()) {
        match seen.get(&i.rel) {
            Some(first) => {
                i.problem = Some(Problem::File(format!(
                    "output name {} is already used by {}",
                    i.rel.display(),
                    first.display()
                )))
            }
            None => {
                seen.insert(i.rel.clone(), i.path.clone());
            }
        }
    }
    Ok(all)
}

/// Input `i` of the sorted list belongs to shard `i % n`.
pub fn shard(all: Vec<Input>, s: Option<Shard>) -> Vec<Input> {
    match s {
        None => all,
        Some(s) => all.into_iter().enumerate().filter(|(i, _)| i % s.n == s.k).map(|(_, x)| x).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_parses_and_splits() {
        assert_eq!("1/3".parse::<Shard>().unwrap(), Shard { k: 1, n: 3 });
        assert!("3/3".parse::<Shard>().is_err());
        assert!("0/0".parse::<Shard>().is_err());
        assert!("x".parse::<Shard>().is_err());
        let all: Vec<Input> = (0..10).map(|i| file_input(PathBuf::from(format!("{i}.png")))).collect();
        let mut got: Vec<PathBuf> =
            (0..3).flat_map(|k| shard(all.clone(), Some(Shard { k, n: 3 })).into_iter().map(|i| i.path)).collect();
        got.sort();
        let mut want: Vec<PathBuf> = all.iter().map(|i| i.path.clone()).collect();
        want.sort();
        assert_eq!(got, want);
    }
}
