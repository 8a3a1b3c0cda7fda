#!/usr/bin/env python3
"""Downloads the test data (../shared/data's layout) and checks it against the manifest.

Run through scripts/fetch_test_data.sh (usage there and in docs/development.md).
Standard library only. Every file is checked against scripts/test_data/manifest.tsv
(size and sha256; for a PNG, its pixels when its bytes differ) before it is moved
into the data folder; a file that does not match is refused, deleted and named.
"""

import argparse
import hashlib
import os
import pathlib
import sys
import tarfile
import tempfile
import urllib.parse
import zipfile
import zlib

import catalog
import pixels
import remote

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[1]
TMP_NAME = ".fetch-tmp"
# What a damaged or unexpected origin can raise (CatalogError, ImageError and a
# calib.txt that is not ASCII are ValueErrors; a truncated archive, EOFError or zlib.error).
PROBLEMS = (remote.FetchError, ValueError, zipfile.BadZipFile, tarfile.TarError, OSError, EOFError, zlib.error)


def sha256(data):
    return hashlib.sha256(data).hexdigest()


def verify(row, data):
    """None when `data` is the file `row` describes, else why not (expected vs actual)."""
    if len(data) == row.size and sha256(data) == row.sha256:
        return None
    why = f"expected {row.size} bytes, sha256 {row.sha256}; got {len(data)} bytes, sha256 {sha256(data)}"
    if row.pixels != "-" and pixels.is_png(data):
        try:
            got = pixels.png_pixel_hash(data)
        except pixels.ImageError as e:
            return f"{why}; not a readable PNG: {e}"
        if got == row.pixels:
            return None
        why += f"; pixels {got}, expected {row.pixels}"
    return why


def check_file(path, row):
    """(state, detail): state is ok, missing or wrong."""
    if not path.is_file():
        return "missing", ""
    why = verify(row, path.read_bytes())
    return ("ok", "") if why is None else ("wrong", why)


# ---------------------------------------------------------------- origins


class Origin:
    """Where the members of one get.NAME are read from."""

    def __init__(self, kind, location, opts, tmp):
        self.kind, self.location, self.opts, self.tmp = kind, location, opts, tmp
        self.url = remote.with_mirror(location, opts.mirror) if kind != "repo" else None
        self._zip = self._tar = self._rangefile = self._downloaded = None
        self._broken = None  # why the archive could not be opened: not tried again

    def describe(self):
        return str(REPO / self.location) if self.kind == "repo" else self.url

    def _local_archive(self):
        if not self.opts.archives:
            return None
        p = pathlib.Path(self.opts.archives) / pathlib.PurePosixPath(urllib.parse.urlsplit(self.location).path).name
        return p if p.is_file() else None

    def get(self, member):
        if self.kind == "repo":
            return (REPO / self.location / member).read_bytes()
        if self.kind == "files":
            fd, tmp = tempfile.mkstemp(dir=self.tmp, suffix=".part")
            os.close(fd)
            try:
                remote.download(self.url + member, tmp)
                return pathlib.Path(tmp).read_bytes()
            finally:
                os.unlink(tmp)
        archive = self._archive()
        if self.kind == "zip":
            return archive.read(member)
        return self._tar_member(archive, member)

    def _archive(self):
        """The open zip or tar; an archive that failed to open is not tried again."""
        if self._broken:
            raise remote.FetchError(self._broken)
        try:
            return self._zipfile() if self.kind == "zip" else self._tarfile()
        except PROBLEMS as e:
            self._broken = f"{self.describe()}: {e}" if self.describe() not in str(e) else str(e)
            raise remote.FetchError(self._broken) from e

    def offset(self, member):
        """Where `member` starts in a zip (to read members in archive order), else 0."""
        if self.kind != "zip":
            return 0
        try:
            return self._archive().getinfo(member).header_offset
        except (KeyError, *PROBLEMS):
            return 0  # the error shows when the member is read

    def _zipfile(self):
        if self._zip is None:
            local = self._local_archive()
            if local:
                print(f"  reading {local}")
                self._zip = zipfile.ZipFile(local)
            else:
                print(f"  reading {self.url} with HTTP Range requests")
                self._rangefile = remote.RangeFile(self.url)
                self._zip = zipfile.ZipFile(self._rangefile)
        return self._zip

    def _tarfile(self):
        if self._tar is None:
            local = self._local_archive()
            if local is None:
                fd, tmp = tempfile.mkstemp(dir=self.tmp, suffix=".tar.gz")
                os.close(fd)
                self._downloaded = pathlib.Path(tmp)
                print(f"  downloading {self.url}")
                remote.download(self.url, tmp)
                local = self._downloaded
            self._tar = tarfile.open(local, "r:gz")
        return self._tar

    def _tar_member(self, tar, member):
        names = [m for m in tar.getmembers() if m.isfile()]
        hits = [m for m in names if m.name == member]
        if not hits:  # the archive may keep its files in a folder
            hits = [m for m in names if pathlib.PurePosixPath(m.name).name == member]
        if len(hits) != 1:
            raise KeyError(f"{member!r} is {'ambiguous' if hits else 'not'} in {self.describe()}")
        return tar.extractfile(hits[0]).read()

    def close(self):
        if self._rangefile is not None:
            rf = self._rangefile
            print(f"{self.url}: read {rf.fetched / 1e6:.1f} MB of {rf.size / 1e6:.1f} MB in {rf.requests} range requests")
        for f in (self._zip, self._tar):
            if f is not None:
                f.close()
        if self._downloaded is not None:
            self._downloaded.unlink(missing_ok=True)


def member_of(rule, row):
    return rule.member + row.path[len(rule.dest) :]


def produce(origin, rule, row):
    """The bytes of `row` from `origin`, transformed and verified (raises on a mismatch)."""
    member = member_of(rule, row)
    if rule.transform == "pnm-png":
        stem = member[: -len(".png")] if member.endswith(".png") else member
        data = None
        for candidate in (stem + ".ppm", stem + ".pgm"):
            try:
                data = origin.get(candidate)
                member = candidate
                break
            except KeyError:
                continue
        if data is None:
            raise KeyError(f"neither {stem}.ppm nor {stem}.pgm is in {origin.describe()}")
        w, h, c, samples = pixels.decode_pnm(data)
        got = pixels.pixel_hash(w, h, c, samples)
        if got != row.pixels:
            raise Refused(f"pixels of {member}: expected {row.pixels}, got {got}")
        return pixels.encode_png(w, h, c, samples)
    data = origin.get(member)
    if rule.transform:
        data = catalog.apply_text_transform(rule.transform, data)
    why = verify(row, data)
    if why:
        raise Refused(f"{why} (from {member})")
    return data


class Refused(Exception):
    """Data that does not match the manifest."""


# ---------------------------------------------------------------- fetch


def place(root, row, data, tmp):
    dest = root / row.path
    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, part = tempfile.mkstemp(dir=tmp, suffix=".part")
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.replace(part, dest)


def fetch_dataset(ds, rows, root, tmp, opts, tally, origins):
    """Fills in the files of one dataset; `origins` keeps the archives opened so far."""
    todo, present = [], 0
    for row in rows:
        state, why = check_file(root / row.path, row)
        if state == "ok":
            present += 1
            continue
        rule = ds.rule_for(row.path)
        if state == "wrong":
            if rule is None or not rule.source:
                print(f"WRONG {row.path}: {why}")
                tally["failed"] += 1
                continue
            print(f"removed {row.path}: it does not match the manifest ({why}); fetching it again")
            (root / row.path).unlink()
        todo.append((row, rule))
    no_origin = [row for row, rule in todo if rule is not None and not rule.source]
    unruled = [row for row, rule in todo if rule is None]
    by_source = {}
    for row, rule in todo:
        if rule is not None and rule.source:
            by_source.setdefault(rule.source, []).append((row, rule))
    print(f"{ds.name}: {len(rows)} files, {present} already present and verified, {len(todo)} to get")
    for row in unruled:
        print(f"FAILED {row.path}: sources.ini has no rule for it")
        tally["failed"] += 1
    if no_origin:
        print(f"  no public origin is recorded for {len(no_origin)} files ({ds.info.get('note', '')}); copy them by hand:")
        for row in no_origin:
            print(f"  missing {row.path}")
        tally["no_origin"] += len(no_origin)
    for name, items in by_source.items():
        kind, location = ds.gets[name]
        origin = origins.get((kind, location))
        if origin is None:
            origin = origins[(kind, location)] = Origin(kind, location, opts, tmp)
        items.sort(key=lambda item: origin.offset(member_of(item[1], item[0])))
        done = 0
        for row, rule in items:
            try:
                data = produce(origin, rule, row)
            except Refused as e:
                print(f"REFUSED {row.path}: {e}; deleted")
                tally["refused"] += 1
                continue
            except (KeyError, *PROBLEMS) as e:
                print(f"FAILED {row.path}: {e}")
                tally["failed"] += 1
                if isinstance(e, remote.FetchError) and kind in ("zip", "tar"):
                    rest = len(items) - items.index((row, rule)) - 1
                    if rest:
                        print(f"  ({rest} more files of {origin.describe()} not tried)")
                        tally["failed"] += rest
                    break
                continue
            place(root, row, data, tmp)
            tally["fetched"] += 1
            done += 1
            if opts.verbose:
                print(f"  ok {row.path}")
            elif done % 100 == 0:
                print(f"  {done}/{len(items)} from {origin.describe()}")
    tally["present"] += present


def cmd_fetch(opts, rows, datasets, chosen):
    root = pathlib.Path(opts.dir).resolve()
    root.mkdir(parents=True, exist_ok=True)
    tmp = root / TMP_NAME
    tmp.mkdir(exist_ok=True)
    tally = dict(present=0, fetched=0, refused=0, failed=0, no_origin=0)
    origins = {}
    try:
        for name in chosen:
            fetch_dataset(datasets[name], [r for r in rows if r.dataset == name], root, tmp, opts, tally, origins)
    finally:
        for origin in origins.values():
            origin.close()
        for p in tmp.iterdir():
            p.unlink()
        tmp.rmdir()
    print(
        f"\n{tally['present']} files were already there, {tally['fetched']} fetched and verified, "
        f"{tally['refused']} refused (checksum mismatch), {tally['failed']} failed, "
        f"{tally['no_origin']} without a public origin."
    )
    bad = tally["refused"] + tally["failed"]
    if bad:
        print(f"error: {bad} files are not in place; see REFUSED / FAILED above", file=sys.stderr)
    print(f"export LFAST_TEST_DATA={root}")
    return 1 if bad else 0


# ---------------------------------------------------------------- check, list, write-manifest


def cmd_check(opts, rows, chosen):
    root = pathlib.Path(opts.check)
    if not root.is_dir():
        print(f"error: {root} is not a folder", file=sys.stderr)
        return 1
    counts = dict(ok=0, missing=0, wrong=0)
    for row in rows:
        if row.dataset not in chosen:
            continue
        state, why = check_file(root / row.path, row)
        counts[state] += 1
        if state != "ok":
            print(f"{state.upper()} {row.path}" + (f": {why}" if why else ""))
    listed = {r.path for r in rows}
    if not opts.only:
        extra = sorted(
            str(p.relative_to(root)) for p in root.rglob("*") if p.is_file() and str(p.relative_to(root)) not in listed
        )
        if extra:
            print(f"note: {len(extra)} files not in the manifest, e.g. {', '.join(extra[:5])}")
    total = sum(counts.values())
    print(f"{root}: {total} files checked against {opts.manifest}: {counts['ok']} ok, {counts['missing']} missing, {counts['wrong']} wrong")
    return 0 if counts["ok"] == total else 1


def cmd_list(rows, datasets):
    for name, ds in datasets.items():
        mine = [r for r in rows if r.dataset == name]
        print(f"{name}: {len(mine)} files, {sum(r.size for r in mine) / 1e6:.1f} MB - {ds.info.get('title', '')}")
        for key in ("licence", "pinned"):
            if key in ds.info:
                print(f"    {key}: {ds.info[key]}")
        for get_name, (kind, location) in ds.gets.items():
            print(f"    {get_name}: {kind} {location}")
    return 0


def cmd_write_manifest(opts, datasets):
    src = pathlib.Path(opts.write_manifest)
    rows = []
    for p in sorted(src.rglob("*")):
        if not p.is_file():
            continue
        rel = p.relative_to(src).as_posix()
        ds = catalog.dataset_of(datasets, rel)
        if ds is None:
            print(f"error: {rel}: no dataset of {opts.sources} claims it", file=sys.stderr)
            return 1
        data = p.read_bytes()
        pix = pixels.png_pixel_hash(data) if pixels.is_png(data) else "-"
        rows.append(catalog.Row(rel, len(data), sha256(data), pix, ds))
    header = [
        "Test data: what each file of the data folder must be (path, size, sha256, pixel hash of a PNG,",
        "dataset of sources.ini). Checked by scripts/fetch_test_data.sh; see docs/development.md.",
        "Written by scripts/fetch_test_data.sh --write-manifest from ../shared/data.",
    ]
    catalog.write_manifest(opts.manifest, rows, header)
    print(f"{opts.manifest}: {len(rows)} files, {sum(r.size for r in rows) / 1e6:.1f} MB")
    return 0


def main(argv=None):
    sys.stdout.reconfigure(line_buffering=True)  # progress in order with stderr, also in CI logs
    ap = argparse.ArgumentParser(prog="scripts/fetch_test_data.sh", description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", nargs="?", help="data folder to fill (created if missing)")
    ap.add_argument("--check", metavar="DIR", help="verify DIR against the manifest; no network")
    ap.add_argument("--only", metavar="LIST", help="comma-separated datasets, or a prefix: kitti = kitti-*")
    ap.add_argument("--list", action="store_true", help="list the datasets, their origins and licences")
    ap.add_argument("--mirror", default=os.environ.get("LFAST_DATA_MIRROR", ""), metavar="URL",
                    help="replace the scheme and host of every origin URL (default: $LFAST_DATA_MIRROR)")
    ap.add_argument("--archives", metavar="DIR", help="folder of archives already downloaded (data_odometry_gray.zip, graf.tar.gz, ...)")
    ap.add_argument("--manifest", default=str(HERE / "manifest.tsv"), metavar="FILE")
    ap.add_argument("--sources", default=str(HERE / "sources.ini"), metavar="FILE")
    ap.add_argument("--write-manifest", metavar="SRC", help="maintainers: rewrite the manifest from the folder SRC")
    ap.add_argument("-v", "--verbose", action="store_true", help="name every file fetched")
    opts = ap.parse_args(argv)
    modes = sum(bool(x) for x in (opts.dir, opts.check, opts.list, opts.write_manifest))
    if modes != 1:
        ap.error("give exactly one of DIR, --check DIR, --list, --write-manifest SRC")
    try:
        datasets = catalog.read_sources(opts.sources)
        if opts.write_manifest:
            return cmd_write_manifest(opts, datasets)
        rows = catalog.read_manifest(opts.manifest)
        unknown = sorted({r.dataset for r in rows} - set(datasets))
        if unknown:
            raise catalog.CatalogError(f"{opts.manifest}: datasets {unknown} are not in {opts.sources}")
        chosen = catalog.select(datasets, opts.only)
    except (catalog.CatalogError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if opts.list:
        return cmd_list(rows, datasets)
    if opts.check:
        return cmd_check(opts, rows, chosen)
    return cmd_fetch(opts, rows, datasets, chosen)


if __name__ == "__main__":
    sys.exit(main())
