"""Tests for vecslice.npz: hostile archives refused before inflating, safe writes.

Every hostile file is generated here, never committed.
"""

from __future__ import annotations

import errno
import io
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import threading
import tracemalloc
import zipfile

import numpy as np
import pytest

import vecslice as vs
from vecslice import InputTypeError, InputValueError, StorageFileError
from vecslice.storage import FORMAT, SlicedModel, load_sliced

FIELDS = SlicedModel.__dataclass_fields__.keys()


def square_model():
    sq = [[0, 0], [1000, 0], [1000, 1000], [0, 1000]]
    return SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4], sq)


def good_arrays(model=None):
    model = model or square_model()
    return {"format": np.array(FORMAT), "version": np.array(1)} | {
        k: getattr(model, k) for k in FIELDS
    }


def npy(arr=None, *, header=None, data=b""):
    """A .npy member: an array, or a hand-made header followed by ``data``."""
    buf = io.BytesIO()
    if arr is not None:
        np.lib.format.write_array(buf, np.asarray(arr), allow_pickle=True)
    else:
        np.lib.format.write_array_header_1_0(buf, header)
        buf.write(data)
    return buf.getvalue()


def write_zip(path, members, *, deflate=False):
    """``members``: name -> bytes, or (header dict, number of zero bytes)."""
    method = zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED
    with zipfile.ZipFile(path, "w", method) as zf:
        for name, member in members.items():
            if isinstance(member, tuple):  # a header, then many zero bytes, streamed
                header, n_zeros = member
                with zf.open(name + ".npy", "w", force_zip64=True) as fh:
                    fh.write(npy(header=header))
                    chunk = bytes(2**22)
                    for start in range(0, n_zeros, len(chunk)):
                        fh.write(chunk[: min(len(chunk), n_zeros - start)])
            else:
                zf.writestr(name + ".npy", member)
    return path


def members_of(arrays):
    return {k: npy(v) for k, v in arrays.items()}


def peak_traced_load(path, **kw):
    tracemalloc.start()
    try:
        with pytest.raises(StorageFileError) as info:
            load_sliced(path, **kw)
        return tracemalloc.get_traced_memory()[1], str(info.value)
    finally:
        tracemalloc.stop()


def test_zip_bomb_is_refused_before_inflating(tmp_path):
    """Issue 8 A7: a 1 MB file cost 2 GB. Here: 256 MiB of zeros in ~250 kB."""
    n = 2**24  # rows of (x, y): 256 MiB
    members = members_of(good_arrays())
    members["coords"] = ({"descr": "<i8", "fortran_order": False,
                          "shape": (n, 2)}, 16 * n)
    path = write_zip(tmp_path / "bomb.npz", members, deflate=True)
    assert os.path.getsize(path) < 2**20
    peak, msg = peak_traced_load(path)
    assert peak < 2**22  # bytes: nothing was inflated
    assert "member 'coords.npy' would inflate" in msg and "zip bomb" in msg


def prism_model(n_layers, ring):
    """``n_layers`` layers of the same ring: its coords repeat every layer."""
    ring = np.asarray(ring, dtype=np.int64)
    z = np.arange(n_layers) * 20 + 10
    steps = np.arange(n_layers + 1)
    return SlicedModel(z, z + 10, np.full(n_layers, 20), steps, steps,
                       steps * len(ring), np.tile(ring, (n_layers, 1)))


@pytest.mark.parametrize(("model", "member"), [
    # a 20 mm square column at 20 µm layers, 400 mm tall (audit s24 D2: 333:1)
    (lambda: prism_model(20_000, [[0, 0], [20_000, 0], [20_000, 20_000],
                                  [0, 20_000]]), "coords.npy"),
    # 300,000 empty layers: the zero per-layer counts deflate about 1000:1
    (lambda: SlicedModel(np.arange(300_000) * 5 + 1, np.arange(300_000) * 5 + 5,
                         np.full(300_000, 5), np.zeros(300_001, np.int64), [0], [0],
                         np.empty((0, 2), np.int64)), "open_chains.npy"),
], ids=["prism", "empty-layers"])
def test_compressed_saves_with_members_beyond_the_ratio_load(tmp_path, model, member):
    # audit s24 D2: save(compress=True) wrote files load_sliced called zip bombs
    m = model()
    m.save(tmp_path / "m.npz", compress=True)
    info = zipfile.ZipFile(tmp_path / "m.npz").getinfo(member)
    assert info.file_size > 2**20
    assert info.file_size > vs.npz.MAX_RATIO * info.compress_size
    back = load_sliced(tmp_path / "m.npz")
    for k in FIELDS:
        assert np.array_equal(getattr(back, k), getattr(m, k)), k


def test_zip_bomb_beyond_max_bytes_is_refused_before_inflating(tmp_path):
    # the total size limit refuses a bomb before anything is inflated, whatever
    # its compression ratio
    n = 2**22  # rows of (x, y): 64 MiB of zeros
    members = members_of(good_arrays())
    members["coords"] = ({"descr": "<i8", "fortran_order": False,
                          "shape": (n, 2)}, 16 * n)
    path = write_zip(tmp_path / "bomb.npz", members, deflate=True)
    peak, msg = peak_traced_load(path, max_bytes=2**25)
    assert peak < 2**22
    assert "holds more than `max_bytes` = 33554432 bytes of arrays" in msg


def test_header_claiming_10_12_rows_is_refused_without_memory_error(tmp_path):
    """Issue 8 C2: a .npy header claiming 10**12 rows raised MemoryError."""
    members = members_of(good_arrays())
    members["coords"] = npy(header={"descr": "<i8", "fortran_order": False,
                                    "shape": (10**12, 2)}, data=bytes(64))
    path = write_zip(tmp_path / "huge.npz", members)
    peak, msg = peak_traced_load(path)
    assert peak < 2**22
    assert "header promises 16000000000000 bytes of data" in msg
    members["coords"] = npy(header={"descr": "<i8", "fortran_order": False,
                                    "shape": (2**28, 2)}, data=bytes(2**32))[:64]
    path = write_zip(tmp_path / "huge2.npz", members)
    peak, msg = peak_traced_load(path, max_bytes=2**20)
    assert peak < 2**22


def test_header_must_agree_with_the_member_size(tmp_path):
    members = members_of(good_arrays())
    members["coords"] = npy(header={"descr": "<i8", "fortran_order": False,
                                    "shape": (1000, 2)}, data=bytes(64))
    path = write_zip(tmp_path / "lie.npz", members)
    with pytest.raises(StorageFileError,
                       match=r"header promises 16000 bytes of data .* holds 64"):
        load_sliced(path)


def test_total_size_limit_can_be_raised(tmp_path):
    model = square_model()
    model.save(tmp_path / "m.npz")
    with pytest.raises(StorageFileError, match=r"`max_bytes` = 100 bytes.*"
                       r"load_sliced\(\.\.\., max_bytes=\.\.\.\)"):
        load_sliced(tmp_path / "m.npz", max_bytes=100)
    assert load_sliced(tmp_path / "m.npz", max_bytes=model.nbytes + 200).n_parts == 1
    with pytest.raises(InputTypeError, match="`max_bytes` must be an integer"):
        load_sliced(tmp_path / "m.npz", max_bytes="1e9")


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        ({"slice_z": np.arange(100_000, dtype=np.int64)},
         "`print_z` must have length 100000 .*got 1"),
        ({"coords": np.zeros((4, 3), np.int64)},
         r"`coords` must have shape \(N, 2\); got shape \(4, 3\)"),
        ({"ring_offsets": np.zeros((2, 2), np.int64)},
         r"`ring_offsets` must have shape \(N,\); got shape \(2, 2\)"),
        ({"ring_offsets": np.arange(50_000, dtype=np.int64)},
         "`ring_offsets` has 50000 entries, too many for 4 vertices"),
        ({"part_offsets": np.arange(7, dtype=np.int64)},
         "`part_offsets` has 7 entries, too many for 1 rings"),
        ({"coords": np.zeros((4, 2), np.float64)},
         "array 'coords' must have dtype int64; got float64"),
    ],
)  # fmt: skip
def test_shapes_are_checked_against_each_other_from_the_headers(
    tmp_path, change, fragment, monkeypatch
):
    from vecslice import npz

    path = write_zip(tmp_path / "s.npz", members_of(good_arrays() | change))
    read = []
    real = npz.read_array
    monkeypatch.setattr("vecslice.storage.read_array",
                        lambda p, zf, m: read.append(m.name) or real(p, zf, m))
    with pytest.raises(StorageFileError, match=fragment):
        load_sliced(path)
    assert set(read) <= {"format", "version"}  # no model array was inflated


@pytest.mark.parametrize(
    ("members", "fragment"),
    [
        (lambda m: m | {"coords": npy(np.array([object()], dtype=object))},
         "holds Python objects; vecslice never unpickles"),
        (lambda m: m | {"coords": npy(np.asfortranarray(np.zeros((4, 2), np.int64)))},
         "Fortran order"),
        (lambda m: m | {"coords": b"\x93NUMPY\x01\x00\x10\x00{'descr': 'garbage"},
         "member 'coords.npy' is not a readable .npy array"),
    ],
)  # fmt: skip
def test_bad_members(tmp_path, members, fragment):
    path = write_zip(tmp_path / "b.npz", members(members_of(good_arrays())))
    with pytest.raises(StorageFileError, match=fragment):
        load_sliced(path)


def test_duplicate_and_encrypted_members(tmp_path):
    members = members_of(good_arrays())
    path = tmp_path / "dup.npz"
    with zipfile.ZipFile(path, "w") as zf, pytest.warns(UserWarning, match="Dupl"):
        for k, v in members.items():
            zf.writestr(k + ".npy", v)
        zf.writestr("coords.npy", members["coords"])
    with pytest.raises(StorageFileError, match=r"member 'coords\.npy' twice"):
        load_sliced(path)
    path = write_zip(tmp_path / "enc.npz", members)
    data = bytearray(path.read_bytes())
    # set the "encrypted" flag of every entry in the central directory
    i = data.find(b"PK\x01\x02")
    while i >= 0:
        data[i + 8] |= 1
        i = data.find(b"PK\x01\x02", i + 4)
    path.write_bytes(bytes(data))
    with pytest.raises(StorageFileError, match="is encrypted"):
        load_sliced(path)


def test_damaged_data_is_caught_by_the_crc(tmp_path):
    path = tmp_path / "m.npz"
    square_model().save(path, compress=False)
    data = bytearray(path.read_bytes())
    i = data.find(np.array([1000, 0], np.int64).tobytes())
    data[i] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(StorageFileError, match=r"coords\.npy.*Bad CRC-32"):
        load_sliced(path)


@pytest.mark.parametrize(
    ("path", "exc", "fragment"),
    [
        # Issue 8 C2: raw TypeError for None; D7: "" gave "Device or resource busy"
        (None, InputTypeError, r"`path` must be a file path \(str or os.PathLike\); "
                               "got NoneType None"),
        (3, InputTypeError, "got int 3"),
        ("", InputValueError, "`path` must be a non-empty file path; got ''"),
        ("a\0b", InputValueError, "must not contain NUL"),
    ],
)  # fmt: skip
def test_bad_paths(path, exc, fragment, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(exc, match=fragment):
        square_model().save(path)
    with pytest.raises(exc, match=fragment):
        load_sliced(path)
    assert os.listdir(tmp_path) == []


@pytest.fixture
def umask():
    old = os.umask(0o022)
    os.umask(old)

    def set_umask(mask):
        os.umask(mask)

    yield set_umask
    os.umask(old)


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600),
                                             (0o002, 0o664)])
def test_new_files_respect_the_umask(tmp_path, umask, mask, mode):
    """Issue 8 D1: saved files were 0600 whatever the umask."""
    umask(mask)
    square_model().save(tmp_path / "m.npz")
    assert stat.S_IMODE(os.stat(tmp_path / "m.npz").st_mode) == mode


def test_overwritten_files_keep_their_mode(tmp_path, umask):
    """Issue 8 D1: an overwritten 0644 file became 0600."""
    umask(0o077)
    path = tmp_path / "m.npz"
    for mode in (0o644, 0o640, 0o604):
        path.write_bytes(b"old")
        os.chmod(path, mode)
        square_model().save(path)
        assert stat.S_IMODE(os.stat(path).st_mode) == mode
        assert load_sliced(path).n_parts == 1


def test_save_writes_through_a_symbolic_link(tmp_path):
    """Issue 8 D9: save() to a symlink replaced the link with a regular file."""
    (tmp_path / "data").mkdir()
    (tmp_path / "links").mkdir()
    target = tmp_path / "data" / "m.npz"
    target.write_bytes(b"old")
    link = tmp_path / "links" / "m.npz"
    link.symlink_to(os.path.join("..", "data", "m.npz"))  # relative link
    chain = tmp_path / "links" / "chain.npz"
    chain.symlink_to(link)
    square_model().save(chain)
    assert chain.is_symlink() and link.is_symlink()
    assert load_sliced(target).n_parts == 1
    assert sorted(os.listdir(tmp_path / "data")) == ["m.npz"]
    assert sorted(os.listdir(tmp_path / "links")) == ["chain.npz", "m.npz"]
    dangling = tmp_path / "links" / "new.npz"
    dangling.symlink_to(tmp_path / "data" / "new.npz")
    square_model().save(dangling)  # as open(): creates the file linked to
    assert dangling.is_symlink() and (tmp_path / "data" / "new.npz").is_file()


def test_symbolic_link_loop_is_named(tmp_path):
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    a.symlink_to(b)
    b.symlink_to(a)
    with pytest.raises(StorageFileError, match=r"a\.npz'.*symbolic link loop"):
        square_model().save(a)
    assert sorted(os.listdir(tmp_path)) == ["a.npz", "b.npz"]


CHILD = r"""
import os, signal, sys, time
import numpy as np
import vecslice as vs
from vecslice.storage import SlicedModel

sq = [[0, 0], [1000, 0], [1000, 1000], [0, 1000]]
model = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4], sq)
mode = sys.argv[2]

def slow_savez(fh, **arrays):
    fh.write(b"partial data")
    fh.flush()
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(30)  # the signal interrupts this

np.savez = slow_savez
if mode == "handled":
    signal.signal(signal.SIGTERM, lambda s, f: sys.exit(3))
print("saving", flush=True)
model.save(os.path.join(sys.argv[1], "m.npz"))
print("not reached", flush=True)
"""


def test_sigterm_during_save_removes_the_temp_file(tmp_path):
    """Issue 8 A8: SIGTERM during save() left a hidden .tmp file."""
    proc = subprocess.run([sys.executable, "-c", CHILD, str(tmp_path), "default"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == -signal.SIGTERM, proc.stderr
    assert proc.stdout == "saving\n"
    assert os.listdir(tmp_path) == []


def test_sigterm_handled_by_the_program_still_removes_the_temp_file(tmp_path):
    proc = subprocess.run([sys.executable, "-c", CHILD, str(tmp_path), "handled"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 3, proc.stderr
    assert os.listdir(tmp_path) == []


def test_sigterm_handler_is_restored_and_threads_can_save(tmp_path):
    before = signal.getsignal(signal.SIGTERM)
    square_model().save(tmp_path / "a.npz")
    assert signal.getsignal(signal.SIGTERM) is before
    errors = []

    def work():
        try:
            square_model().save(tmp_path / "t.npz")
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    t = threading.Thread(target=work)
    t.start()
    t.join()
    assert errors == [] and load_sliced(tmp_path / "t.npz").n_layers == 1
    assert vs.load_sliced(tmp_path / "a.npz").n_layers == 1


def test_damaged_files_always_raise_storage_file_error(tmp_path):
    """Random byte flips, truncations, header edits: never a raw builtin error."""
    import random

    sq = [[0, 0], [1000, 0], [1000, 1000], [0, 1000]]
    hole = [[200, 200], [200, 800], [800, 800], [800, 200]]
    model = SlicedModel([100, 200], [200, 300], [200, 100], [0, 1, 2], [0, 2, 3],
                        [0, 4, 8, 12], sq + hole + sq)
    originals = []
    for compress in (False, True):
        model.save(tmp_path / "m.npz", compress=compress)
        originals.append((tmp_path / "m.npz").read_bytes())
    rng = random.Random(20240611)
    path = tmp_path / "f.npz"
    for i in range(400):
        data = bytearray(originals[i % 2])
        kind = i % 4
        if kind == 0:
            for _ in range(rng.randrange(1, 5)):
                data[rng.randrange(len(data))] = rng.randrange(256)
        elif kind == 1:
            data = data[: rng.randrange(len(data))]
        elif kind == 2:
            j = data.find(b"{'descr'", rng.randrange(len(data)))
            if j >= 0:
                data[j + rng.randrange(1, 60)] = rng.choice(b"(){}[]',:0129af \\\"")
        else:
            j = rng.randrange(len(data))
            data[j : j + rng.randrange(1, 20)] = rng.randbytes(rng.randrange(30))
        path.write_bytes(bytes(data))
        try:
            back = load_sliced(path)
        except StorageFileError:
            continue
        assert back.layer_areas().tolist() == model.layer_areas().tolist()


# --- special files: never read, never replaced (audit s23 D4, D5, D13) ---------

# run in a child process, so that a regression (a read that blocks on a FIFO or
# never ends on /dev/zero) fails the test instead of hanging the suite
SPECIAL_CHILD = r"""
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
import vecslice as vs
try:
    vs.load_sliced(sys.argv[1])
except vs.StorageFileError as exc:
    print("refused:", exc)
"""


def _load_in_child(path, prefix=()):
    return subprocess.run(
        [*prefix, sys.executable, "-c", SPECIAL_CHILD, str(path)],
        capture_output=True, text=True, timeout=60, check=False,
    )


def _char_device(path):
    """A private copy of /dev/null at ``path`` (needs root), else None."""
    try:
        os.mknod(path, 0o644 | stat.S_IFCHR, os.makedev(1, 3))
    except (PermissionError, AttributeError):
        return None
    return path


@pytest.mark.parametrize(("make", "kind"), [
    (lambda p: os.mkfifo(p) or p, "is a FIFO \\(named pipe\\), not a regular file"),
    (lambda p: os.symlink("/dev/zero", p) or p,
     "is a character device, not a regular file"),
])  # fmt: skip
def test_load_refuses_fifos_and_devices_at_once(tmp_path, make, kind):
    """Audit s23 D5: a FIFO blocked forever, /dev/zero gave a raw MemoryError."""
    path = make(tmp_path / "m.npz")
    proc = _load_in_child(path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.startswith("refused: "), proc.stdout
    assert re.search(f"'{re.escape(str(path))}' {kind}", proc.stdout), proc.stdout
    with pytest.raises(StorageFileError, match=kind) as info:  # in process, too
        load_sliced(path)
    assert isinstance(info.value, OSError)


def test_unreadable_file_says_permission_denied(tmp_path):
    """Audit s23 D13: "is not an .npz file written by ... (Permission denied)"."""
    path = tmp_path / "m.npz"
    square_model().save(path)
    os.chmod(path, 0)
    prefix = ()
    if os.geteuid() == 0:  # root reads anything: drop its capabilities
        if not shutil.which("setpriv"):
            pytest.skip("running as root without setpriv")
        prefix = ("setpriv", "--bounding-set=-all", "--inh-caps=-all")
    proc = _load_in_child(path, prefix)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == f"refused: cannot read '{path}': permission denied"


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_save_never_replaces_a_fifo_or_a_device(tmp_path, kind):
    """Audit s23 D4: save() onto a FIFO or a device replaced it by a regular file."""
    path = tmp_path / "out.npz"
    if kind == "fifo":
        os.mkfifo(path)
        fragment = "it is a FIFO \\(named pipe\\), not a regular file"
    elif _char_device(path) is None:
        pytest.skip("creating a device needs root")
    else:
        fragment = "it is a character device, not a regular file"
    link = tmp_path / "link.npz"
    link.symlink_to(path)
    for target in (path, link):
        with pytest.raises(StorageFileError, match=fragment) as info:
            square_model().save(target)
        assert isinstance(info.value, OSError) and str(target) in str(info.value)
    mode = os.lstat(path).st_mode
    assert (stat.S_ISFIFO if kind == "fifo" else stat.S_ISCHR)(mode)
    assert sorted(os.listdir(tmp_path)) == ["link.npz", "out.npz"]  # no temp file


def test_save_refuses_a_read_only_file(tmp_path, umask):
    """Audit s23 D13: a 0444 file was silently replaced (even for a non-root user,
    since the rename needs only the directory's permission)."""
    path = tmp_path / "m.npz"
    path.write_bytes(b"keep me")
    for mode in (0o444, 0o400, 0o000):
        os.chmod(path, mode)
        with pytest.raises(StorageFileError,
                           match=f"'{re.escape(str(path))}': it is read-only "
                                 f"\\(mode {mode:04o}\\); make it writable"):
            square_model().save(path)
        assert path.read_bytes() == b"keep me"
        assert stat.S_IMODE(os.stat(path).st_mode) == mode
    assert os.listdir(tmp_path) == ["m.npz"]
    os.chmod(path, 0o644)  # writable again: replaced, mode kept
    square_model().save(path)
    assert load_sliced(path).n_parts == 1
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o644


def test_write_atomic_names_what_it_writes(tmp_path):
    """Audit s24 D6: a failed PNG, SVG or page write said "cannot save a vecslice
    model"."""
    from vecslice.npz import write_atomic

    def full(fh):
        fh.write(b"part")
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))

    path = str(tmp_path / "layer.png")
    with pytest.raises(StorageFileError, match=re.escape(
            f"cannot save a PNG picture to {path!r}: File too large")):
        write_atomic(path, full, what="a PNG picture")
    with pytest.raises(StorageFileError, match=re.escape(
            f"cannot save a vecslice model to {path!r}: File too large")):
        write_atomic(path, full)  # the default
    os.mkfifo(tmp_path / "fifo.svg")
    with pytest.raises(StorageFileError, match=r"cannot save an SVG picture to "
                       r".*fifo\.svg': it is a FIFO"):
        write_atomic(str(tmp_path / "fifo.svg"), full, what="an SVG picture")
    assert sorted(os.listdir(tmp_path)) == ["fifo.svg"]


def test_missing_directory_is_named_before_writing(tmp_path):
    """Audit s24 D8: a dangling symbolic link into a missing directory was found
    only when the write failed, and the message did not name the directory."""
    from vecslice.npz import check_target

    link = tmp_path / "out.npz"
    link.symlink_to(tmp_path / "gone" / "deeper" / "m.npz")
    folder = str(tmp_path / "gone" / "deeper")
    with pytest.raises(StorageFileError, match=re.escape(
            f"-o 'out.npz': it is a symbolic link to '{folder}/m.npz', whose "
            f"directory '{folder}' does not exist")):
        check_target(str(link), where="-o 'out.npz'")
    with pytest.raises(StorageFileError, match=re.escape(
            f"cannot save a vecslice model to '{link}': it is a symbolic link to "
            f"'{folder}/m.npz', whose directory '{folder}' does not exist")):
        square_model().save(link)
    missing = str(tmp_path / "nope" / "m.npz")
    with pytest.raises(StorageFileError, match=re.escape(
            f"cannot write '{missing}': the directory '{tmp_path}/nope' does not "
            "exist")):
        check_target(missing)
    assert os.listdir(tmp_path) == ["out.npz"]
    (tmp_path / "gone" / "deeper").mkdir(parents=True)  # then the link is fine
    assert check_target(str(link)) == f"{folder}/m.npz"
