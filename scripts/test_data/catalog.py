"""The committed manifest (what each file must be) and sources (where it comes from).

manifest.tsv: one row a file of the test-data folder,
    path <TAB> size <TAB> sha256 <TAB> pixels <TAB> dataset
`pixels` is pixels.pixel_hash of a PNG's decoded samples, `-` for other files.

sources.ini: one section a dataset, with
    get.NAME = KIND LOCATION   where to read from; KIND is
        files  LOCATION is a base URL, the member is appended to it
        zip    LOCATION is a zip's URL, read with HTTP Range requests
        tar    LOCATION is a .tar.gz's URL, downloaded whole
        repo   LOCATION is a folder of this repository
    files = lines of  DEST  NAME:MEMBER  [TRANSFORM]
        DEST is a path of the test-data folder, or a prefix of such paths (the rest of
        the path is appended to MEMBER); the longest DEST that matches a path wins.
        `-` instead of NAME:MEMBER: no public origin is recorded.
        TRANSFORM: head=N (first N lines), kitti-calib-p0p1, pnm-png.
"""

import configparser
import pathlib
from dataclasses import dataclass

KINDS = ("files", "zip", "tar", "repo")
TRANSFORMS = ("kitti-calib-p0p1", "pnm-png")


class CatalogError(ValueError):
    """A manifest or sources file that does not parse; the message says where."""


@dataclass(frozen=True)
class Row:
    path: str
    size: int
    sha256: str
    pixels: str  # "-" when not a PNG
    dataset: str


@dataclass(frozen=True)
class Rule:
    dest: str
    source: str  # NAME of a get.NAME, or "" when there is no origin
    member: str
    transform: str  # "" for a plain copy


@dataclass
class Dataset:
    name: str
    info: dict  # title, licence, pinned, ... as written
    gets: dict  # NAME -> (kind, location)
    rules: list

    def rule_for(self, path):
        best = None
        for r in self.rules:
            if path.startswith(r.dest) and (best is None or len(r.dest) > len(best.dest)):
                best = r
        return best


def read_manifest(path):
    rows = []
    for n, line in enumerate(pathlib.Path(path).read_text().splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        f = line.split("\t")
        if len(f) != 5:
            raise CatalogError(f"{path}:{n}: {len(f)} tab-separated fields, 5 expected")
        p, size, sha, pix, ds = f
        if not size.isdigit() or len(sha) != 64 or not (pix == "-" or len(pix) == 64):
            raise CatalogError(f"{path}:{n}: bad size, sha256 or pixels field")
        if p.startswith("/") or ".." in p.split("/"):
            raise CatalogError(f"{path}:{n}: path {p!r} leaves the data folder")
        rows.append(Row(p, int(size), sha, pix, ds))
    if len({r.path for r in rows}) != len(rows):
        raise CatalogError(f"{path}: a path is listed twice")
    return rows


def write_manifest(path, rows, header):
    lines = [f"# {h}" if h else "#" for h in header]
    lines.append("# path\tsize\tsha256\tpixels\tdataset")
    for r in sorted(rows, key=lambda r: r.path):
        lines.append(f"{r.path}\t{r.size}\t{r.sha256}\t{r.pixels}\t{r.dataset}")
    pathlib.Path(path).write_text("\n".join(lines) + "\n")


def _rule(section, line):
    f = line.split()
    if len(f) not in (2, 3):
        raise CatalogError(f"[{section}] files: {line!r}: DEST SOURCE [TRANSFORM] expected")
    dest, src = f[0], f[1]
    transform = f[2] if len(f) == 3 else ""
    if transform and transform not in TRANSFORMS and not _head_lines(transform):
        raise CatalogError(f"[{section}] files: unknown transform {transform!r}")
    if src == "-":
        return Rule(dest, "", "", transform)
    name, sep, member = src.partition(":")
    if not sep:
        raise CatalogError(f"[{section}] files: {src!r} is not NAME:MEMBER")
    return Rule(dest, name, member, transform)


def _head_lines(transform):
    """N of a head=N transform, else None."""
    if transform.startswith("head=") and transform[5:].isdigit():
        return int(transform[5:])
    return None


def read_sources(path):
    cp = configparser.ConfigParser(interpolation=None)
    try:
        with open(path) as f:
            cp.read_file(f)
    except configparser.Error as e:
        raise CatalogError(f"{path}: {e}") from e
    datasets = {}
    for name in cp.sections():
        sec = cp[name]
        gets, info = {}, {}
        for key, value in sec.items():
            if key.startswith("get."):
                kind, _, location = value.strip().partition(" ")
                if kind not in KINDS or not location.strip():
                    raise CatalogError(f"{path}: [{name}] {key}: KIND LOCATION with KIND in {KINDS} expected")
                gets[key[4:]] = (kind, location.strip())
            elif key != "files":
                info[key] = " ".join(value.split())
        rules = [_rule(name, line) for line in sec.get("files", "").splitlines() if line.strip()]
        for r in rules:
            if r.source and r.source not in gets:
                raise CatalogError(f"{path}: [{name}] files: {r.dest} reads from {r.source!r}, which has no get.{r.source}")
        datasets[name] = Dataset(name, info, gets, rules)
    return datasets


def dataset_of(datasets, path):
    """The dataset whose rules claim `path` (longest DEST over all datasets), or None."""
    best, best_len = None, -1
    for d in datasets.values():
        r = d.rule_for(path)
        if r is not None and len(r.dest) > best_len:
            best, best_len = d.name, len(r.dest)
    return best


def select(datasets, only):
    """Names chosen by --only: exact names, or a prefix before '-' (kitti = kitti-*)."""
    if not only:
        return list(datasets)
    chosen = []
    for want in only.split(","):
        want = want.strip()
        hits = [n for n in datasets if n == want or n.startswith(want + "-")]
        if not hits:
            raise CatalogError(f"--only: no dataset {want!r} (datasets: {', '.join(datasets)})")
        chosen += [h for h in hits if h not in chosen]
    return chosen


def apply_text_transform(transform, data):
    """head=N and kitti-calib-p0p1 (pnm-png works on images: see fetch.py)."""
    n = _head_lines(transform)
    if n is not None:
        lines = data.splitlines(keepends=True)
        if len(lines) < n:
            raise CatalogError(f"head={n}: the source has only {len(lines)} lines")
        return b"".join(lines[:n])
    if transform == "kitti-calib-p0p1":
        # KITTI's calib.txt: "P0: 12 numbers" ... "P3: ...", maybe "Tr: ...". The
        # test-data folder keeps the numbers of P0 and P1, one row each, no labels,
        # rows joined by a newline and no newline after the last one.
        rows = {}
        for line in data.decode("ascii").splitlines():
            label, _, rest = line.partition(":")
            if label.strip() in ("P0", "P1"):
                numbers = rest.split()
                if len(numbers) != 12:
                    raise CatalogError(f"calib.txt: {label.strip()} holds {len(numbers)} numbers, 12 expected")
                rows[label.strip()] = " ".join(numbers)
        if set(rows) != {"P0", "P1"}:
            raise CatalogError("calib.txt: no P0 and P1 rows")
        return (rows["P0"] + "\n" + rows["P1"]).encode("ascii")
    raise CatalogError(f"no text transform {transform!r}")
