import os
import signal
import sys
import threading
import time

import numba
import numpy as np
import pytest
import trimesh

import vecslice as vs
from vecslice.sweeps import METRIC_COLUMNS, _schedule_groups, _variant

MESHES3 = ("Voron_Design_Cube_v7.stl", "teapot.stl", "pyramids.3mf")
GRID6 = {"max_resolution": [200, 800, 2000], "max_deviation": [10, 50],
         "layer_height": [400]}


@pytest.fixture(scope="module")
def box():
    return vs.load_mesh(trimesh.creation.box((10, 10, 2)))


@pytest.fixture(scope="module")
def three(meshes_dir):
    return {name: str(meshes_dir / name) for name in MESHES3}


def _same_table(a, b):
    a = a.drop(columns=["seconds", "prep_seconds"])
    b = b.drop(columns=["seconds", "prep_seconds"])
    assert list(a.columns) == list(b.columns)
    import pandas.testing as pdt

    pdt.assert_frame_equal(a, b, check_exact=True)


def test_columns_and_rows(box):
    t = vs.sweep({"box": box}, {"max_resolution": [200, 500], "layer_height": [100]})
    names = ["mesh", *vs.SliceSettings.option_names(), *METRIC_COLUMNS, "error"]
    assert list(t.columns) == names
    for must in ("layers", "raw_vertices", "vertices", "parts", "max_deviation_um",
                 "area_error_um2", "relative_area_error", "volume_error_mm3",
                 "short_move_fraction", "moves_per_s", "seconds"):
        assert must in t.columns
    assert t["max_resolution"].tolist() == [200, 500]
    assert (t["error"] == "").all() and (t["layers"] == 18).all()


def test_rows_equal_slice_mesh_and_metrics(meshes_dir):
    mesh = vs.load_mesh(meshes_dir / "Voron_Design_Cube_v7.stl")
    grid = {"max_resolution": [300, 1500], "max_deviation": [20, 80],
            "layer_height": [300], "slicing_tolerance": ["middle", "inclusive"]}
    t = vs.sweep({"voron": mesh}, grid)
    for row in t.itertuples():
        s = vs.SliceSettings(**{k: getattr(row, k) for k in grid})
        model = vs.slice_mesh(mesh, s)
        assert (row.layers, row.vertices, row.parts) == (
            model.n_layers, model.coords.shape[0], model.n_parts)
        raw = vs.slice_contours(mesh, model.slice_z)
        err, _ = vs.metrics.simplification_errors(raw, s)
        assert row.raw_vertices == raw.coords.shape[0]
        assert row.max_deviation_um == err.max_deviation_um
        assert row.area_error_um2 == err.area_error_um2
        assert row.relative_area_error == err.relative_area_error
        moves = vs.metrics.move_stats(model)
        assert row.short_move_fraction == moves.short_move_fraction
        assert row.moves_per_s == moves.moves_per_s
        vol = vs.metrics.volume_error(model, mesh)
        assert row.volume_error_mm3 == vol.volume_error_mm3
        assert row.staircase_error_mm3 == vol.staircase_error_mm3
        assert row.relative_staircase_error == vol.relative_staircase_error


def test_variant_is_slice_mesh(meshes_dir):
    mesh = vs.load_mesh(meshes_dir / "teapot.stl")  # open: stitching, open chains
    for s in (vs.SliceSettings(), vs.SliceSettings(slicing_tolerance="exclusive",
                                                   max_resolution=1000)):
        sched = vs.layer_heights(mesh, s)
        raw, stitched = vs.stitch(vs.slice_contours(mesh, sched[0], stitch=False))
        got, _ = _variant(raw, stitched, sched, s)
        want = vs.slice_mesh(mesh, s)
        for f in ("coords", "ring_offsets", "part_offsets", "layer_offsets",
                  "slice_z", "print_z", "thickness", "open_chains", "stitched_gaps",
                  "open_coords"):
            assert np.array_equal(getattr(got, f), getattr(want, f)), f


def test_schedule_groups_share_raw_contours():
    combos = [vs.SliceSettings(max_resolution=r, layer_height=h)
              for h in (100, 200) for r in (100, 500, 900)]
    groups = _schedule_groups(combos)
    assert [[i for i, _ in g] for g in groups] == [[0, 1, 2], [3, 4, 5]]


def test_adaptive_settings_split_groups_only_with_adaptive_layers():
    # uniform combinations differing only in adaptive_* share one schedule
    # (audit s26: 8 combinations were 8 tasks instead of 5)
    combos = [vs.SliceSettings(adaptive_layers=a, adaptive_threshold=t)
              for a in (False, True) for t in (50, 100, 200, 400)]
    groups = _schedule_groups(combos)
    assert [[i for i, _ in g] for g in groups] == [[0, 1, 2, 3], [4], [5], [6], [7]]
    combos = [vs.SliceSettings(adaptive_variation=v, adaptive_variation_step=st)
              for v in (50, 100) for st in (5, 10)]
    assert len(_schedule_groups(combos)) == 1


def test_bad_mesh_gives_error_rows(tmp_path, box):
    junk = tmp_path / "junk.stl"
    junk.write_bytes(b"solid nothing here\n" * 3)
    t = vs.sweep([junk, box, tmp_path / "missing.obj"], {"max_deviation": [10, 30]})
    assert t["mesh"].tolist() == ["junk.stl"] * 2 + ["mesh1"] * 2 + ["missing.obj"] * 2
    bad = t[t["mesh"] != "mesh1"]
    assert bad["error"].str.contains("MeshFileError").all()
    assert bad[list(METRIC_COLUMNS)].isna().all().all()
    good = t[t["mesh"] == "mesh1"]
    assert (good["error"] == "").all() and good["vertices"].notna().all()


@pytest.mark.parametrize("grid, match", [
    ({"max_resolutoin": [1]}, r"unknown setting 'max_resolutoin'.*max_resolution"),
    ({"max_deviation": [-1]}, "`max_deviation` must be >= 0"),
    ({"slicing_tolerance": ["sideways"]}, "`slicing_tolerance` must be one of"),
    ({"layer_height": [0.5]}, "layer_height"),
    ({}, "at least one setting"),
    ([], "at least one combination"),
    ({"max_deviation": []}, "at least one value"),
    ([{"max_deviation": 3}, "x"], r"`grid\[1\]` must be a dict"),
    ("max_deviation", "must be a dict"),
])
def test_bad_grid_is_a_settings_error_before_any_work(grid, match, monkeypatch, box):
    import vecslice.sweeps as sw

    monkeypatch.setattr(sw, "_prepare", None)  # any work would fail differently
    with pytest.raises(vs.SettingsError, match=match):
        vs.sweep({"box": box}, grid)


def test_bad_arguments(box):
    with pytest.raises(vs.SettingsError, match="`speed_mm_s` must be finite and > 0"):
        vs.sweep(box, {"max_deviation": 5}, speed_mm_s=-1)
    with pytest.raises(vs.SettingsError, match="`controller_ms`"):
        vs.sweep(box, {"max_deviation": 5}, controller_ms=float("inf"))
    with pytest.raises(vs.InputValueError, match="unique names"):
        vs.sweep(["a/x.stl", "b/x.stl"], {"max_deviation": 5})
    with pytest.raises(vs.InputTypeError, match="`meshes` must be"):
        vs.sweep(3, {"max_deviation": 5})
    with pytest.raises(vs.InputValueError, match="at least one mesh"):
        vs.sweep([], {"max_deviation": 5})
    with pytest.raises(vs.InputTypeError, match="`client` must be a distributed"):
        vs.sweep(box, {"max_deviation": 5}, client="localhost")
    with pytest.raises(vs.InputValueError, match="`scale` must name meshes"):
        vs.sweep({"a": box}, {"max_deviation": 5}, scale={"b": 2.0})


def test_grid_values_of_any_ordered_kind(box):
    import pandas as pd

    want = vs.sweep(box, {"max_resolution": [500]})
    for value in (np.array(500), np.int32(500), (500,), pd.Series([500]),
                  range(500, 501)):
        got = vs.sweep(box, {"max_resolution": value})
        _same_table(got, want)
    with pytest.raises(vs.SettingsError, match=r"a set has no order.*\{200, 500\}"):
        vs.sweep(box, {"max_resolution": {200, 500}})
    # a value of the wrong type: a SettingsError, and a TypeError like SliceSettings'
    with pytest.raises(vs.SettingsError, match="integer number of µm; got str '500'"
                       ) as info:
        vs.sweep(box, {"max_resolution": ["500"]})
    assert isinstance(info.value, TypeError)
    with pytest.raises(TypeError, match="True or False; got int 1"):
        vs.sweep(box, [{"union_overlapping_volumes": 1}])


def test_scale_applies_to_paths_only(meshes_dir, box):
    path = str(meshes_dir / "Voron_Design_Cube_v7.stl")
    with pytest.raises(vs.InputValueError, match=r"'b' is a vecslice\.Mesh"):
        vs.sweep({"a": path, "b": box}, {"max_deviation": 5}, scale={"b": 2.0})
    with pytest.raises(vs.InputValueError, match=r"only vecslice\.Mesh objects"):
        vs.sweep({"b": box}, {"max_deviation": 5}, scale=25.4)
    t = vs.sweep({"a": path, "b": box}, {"layer_height": [400]}, scale={"a": 2.0})
    scaled = vs.load_mesh(path, scale=2.0)
    assert t["height_um"].tolist() == [int(np.ptp(scaled.vertices[:, 2])),
                                       int(np.ptp(box.vertices[:, 2]))]
    assert t["height_um"][0] == 2 * int(np.ptp(vs.load_mesh(path).vertices[:, 2]))


def test_arguments_of_other_types(box):
    with pytest.raises(vs.InputTypeError, match=r"got bytes b'x.stl' \(decode it\)"):
        vs.sweep(b"x.stl", {"max_deviation": 5})
    with pytest.raises(vs.InputTypeError, match="`progress` must be True or False"):
        vs.sweep(box, {"max_deviation": 5}, progress="yes")
    t = vs.sweep(box, {"max_deviation": 5}, progress=np.False_)
    assert (t["error"] == "").all()


def test_cura_rows_read_paths_as_curaengine(meshes_dir):
    # the 1000-gon cylinder: CuraEngine's reading (30 µm melding) changes the polygons
    path = meshes_dir / "cura" / "cylinder1000.stl"
    t = vs.sweep({"cyl": str(path)}, [{"compat": "cura"}, {}])
    cura = vs.slice_mesh(vs.load_mesh(path, compat="cura"),
                         vs.SliceSettings(compat="cura"))
    plain = vs.slice_mesh(vs.load_mesh(path), vs.SliceSettings())
    assert (t["error"] == "").all()
    assert t["vertices"].tolist() == [cura.coords.shape[0], plain.coords.shape[0]]
    as_default = vs.slice_mesh(vs.load_mesh(path), vs.SliceSettings(compat="cura"))
    assert as_default.coords.shape[0] != cura.coords.shape[0]  # the reading matters


def test_each_mesh_is_prepared_once_per_way_of_reading_it(monkeypatch, meshes_dir,
                                                          box):
    import vecslice.sweeps as sw

    calls = []
    real = sw._prepare

    def spy(source, scale, compat="vecslice"):
        calls.append((str(source)[-8:], compat))
        return real(source, scale, compat)

    monkeypatch.setattr(sw, "_prepare", spy)
    grid = [{"compat": "cura"}, {}, {"compat": "cura", "layer_height": 300}]
    vs.sweep({"box": box}, grid)
    assert calls == [(str(box)[-8:], "vecslice")]  # a Mesh: once, used as it is
    calls.clear()
    vs.sweep({"cyl": str(meshes_dir / "cura" / "cylinder1000.stl")}, grid)
    assert sorted(calls) == [("1000.stl", "cura"), ("1000.stl", "vecslice")]


def test_missing_dependencies_name_the_extra(monkeypatch, box):
    """A vecslice error (audit s25 docs D3: a plain ImportError), naming all that
    is missing."""
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(vs.MissingDependencyError,
                       match=r"\(pandas is not installed\): pip install "
                             r"'vecslice\[sweep\]'"):
        vs.sweep(box, {"max_deviation": 5})
    monkeypatch.setitem(sys.modules, "dask", None)
    with pytest.raises(vs.MissingDependencyError,
                       match=r"\(pandas and dask are not installed\)"):
        vs.sweep(box, {"max_deviation": 5})


def test_import_vecslice_does_not_import_pandas_or_dask():
    import subprocess

    code = ("import sys, vecslice; "
            "print(any(m in sys.modules for m in ('pandas', 'dask', 'distributed')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True,
                         text=True, check=True)
    assert out.stdout.strip() == "False"


def test_progress_bar(box, capsys):
    t = vs.sweep(box, {"max_deviation": [5, 10]}, progress=True)
    assert len(t) == 2
    assert "sweep" in capsys.readouterr().err


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as c, \
            distributed.Client(c) as client:
        yield c, client


def test_distributed_table_equals_local(three, cluster):
    _, client = cluster
    local = vs.sweep(three, GRID6)
    remote = vs.sweep(three, GRID6, client=client)
    assert len(local) == 3 * 6 and (local["error"] == "").all()
    _same_table(local, remote)


def test_killed_worker_mid_sweep_still_completes(three, cluster):
    c, client = cluster
    grid = {**GRID6, "layer_height": [300, 400, 500]}  # 9 tasks of 6 rows
    local = vs.sweep(three, grid)
    killed = []

    def kill_one_busy_worker():
        deadline = time.time() + 120
        while time.time() < deadline and not killed:
            busy = [w for w, keys in client.processing().items() if keys]
            if busy:
                pids = client.run(os.getpid, workers=[busy[0]])
                pid = pids[busy[0]]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            time.sleep(0.05)

    th = threading.Thread(target=kill_one_busy_worker)
    th.start()
    remote = vs.sweep(three, grid, client=client)
    th.join()
    assert killed, "no worker was busy to kill"
    assert (remote["error"] == "").all()
    _same_table(local, remote)


def test_adaptive_and_cura_rows(box):
    t = vs.sweep(box, [{"adaptive_layers": True}, {"compat": "cura"}, {}])
    assert (t["error"] == "").all()
    for k, s in enumerate([vs.SliceSettings(adaptive_layers=True),
                           vs.SliceSettings(compat="cura"), vs.SliceSettings()]):
        model = vs.slice_mesh(box, s)
        assert (t["layers"][k], t["vertices"][k]) == (model.n_layers,
                                                      model.coords.shape[0])
    assert np.isnan(t["max_deviation_um"][1]) and t["max_deviation_um"][2] == 0.0


def test_max_layers_gives_error_rows(box):
    t = vs.sweep(box, {"max_layers": [5], "layer_height": [100]})
    assert t["error"][0].startswith("SettingsError") and np.isnan(t["layers"][0])


_SWEEP_ON_WORKQUEUE = r"""
import dask, numba
import vecslice as vs

used = []
compute = dask.compute


def spy(*args, **kw):
    used.append(kw.get("scheduler"))
    return compute(*args, **kw)


dask.compute = spy
meshes = {"a": vs.demo_mesh(segments=192), "b": vs.demo_mesh(segments=256)}
grid = [{"adaptive_layers": True}, {"compat": "cura"},
        {"adaptive_layers": True, "compat": "cura"}, {}]
t = vs.sweep(meshes, grid)
assert used == ["threads"], used
assert (t["error"] == "").all(), t["error"].tolist()
for row in t.itertuples():
    s = vs.SliceSettings(adaptive_layers=row.adaptive_layers, compat=row.compat)
    model = vs.slice_mesh(meshes[row.mesh], s)
    assert (row.layers, row.vertices) == (model.n_layers, model.coords.shape[0])
print("ok", len(t), numba.threading_layer())
"""


@pytest.mark.skipif(numba.config.DISABLE_JIT,
                    reason="NUMBA_DISABLE_JIT=1: nothing compiled, too slow as Python")
def test_sweep_runs_on_threads_on_numbas_workqueue_layer(tmp_path):
    """Dask's threads on numba's workqueue layer too: no kernel is a parfor.

    That layer (numba's fallback without OpenMP or TBB) aborts the process when
    two threads run parfors at once; the sweep ran serially there while the cura
    and adaptive kernels were parfors.
    """
    import subprocess

    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue")
    p = subprocess.run([sys.executable, "-c", _SWEEP_ON_WORKQUEUE], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    assert p.stdout.split() == ["ok", "8", "workqueue"]


@pytest.mark.parametrize("stage", ["simplify", "parts", "errors"])
def test_a_failing_combination_gives_its_row_an_error(monkeypatch, stage):
    # the combinations run as a pipeline (the next one simplified, this one's
    # errors measured on other threads): a failure in any stage of one
    # combination fills its row's error, and the others come out as without it
    import vecslice.pipeline as pipeline
    import vecslice.sweeps as sweeps
    from vecslice.errorcache import ErrorCache

    # 64-gon layers with ~490 µm edges: each max_resolution keeps other vertices
    mesh = vs.load_mesh(trimesh.creation.cylinder(5, 2, sections=64))
    grid = {"max_resolution": [200, 500, 900], "layer_height": [100]}
    clean = vs.sweep({"cyl": mesh}, grid)
    raw = vs.slice_contours(mesh, vs.layer_heights(mesh, vs.SliceSettings())[0])
    sizes = [pipeline._clean_closed(raw, vs.SliceSettings(max_resolution=r))[0]
             .shape[0] for r in grid["max_resolution"]]
    assert len(set(sizes)) == 3
    module, name, is_target = {
        "simplify": (pipeline, "_clean_closed",
                     lambda a: a[1].max_resolution == 500),
        "parts": (sweeps, "_model", lambda a: a[3].max_resolution == 500),
        "errors": (ErrorCache, "errors", lambda a: a[1].shape[0] == sizes[1]),
    }[stage]
    real = getattr(module, name)

    def failing(*args, **kw):
        if is_target(args):
            raise RuntimeError(f"{stage} failed")
        return real(*args, **kw)

    monkeypatch.setattr(module, name, failing)
    t = vs.sweep({"cyl": mesh}, grid)
    failed = (t["error"] != "").to_numpy()
    assert failed.tolist() == [False, True, False]
    assert t["error"][1] == f"RuntimeError: {stage} failed"
    assert np.isnan(t["vertices"][1]) and np.isnan(t["max_deviation_um"][1])
    _same_table(t[~failed].reset_index(drop=True).astype(clean.dtypes.to_dict()),
                clean[~failed].reset_index(drop=True))


def test_helper_threads_run_their_kernels_alone_and_lower(monkeypatch, box):
    # the pipeline's helpers (simplifying ahead, measuring errors) use one numba
    # thread each and, on Linux, a nice value HELPER_NICE above the thread that
    # started them; the caller's own thread keeps its priority
    import numba

    import vecslice.pipeline as pipeline
    import vecslice.sweeps as sweeps

    linux = sys.platform.startswith("linux")
    seen = []
    real = pipeline._clean_closed

    def spy(*args, **kw):
        tid = threading.get_native_id()
        seen.append((threading.current_thread().name, numba.get_num_threads(),
                     os.getpriority(os.PRIO_PROCESS, tid) if linux else None))
        return real(*args, **kw)

    monkeypatch.setattr(pipeline, "_clean_closed", spy)
    base = os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) if linux else None
    threads = numba.get_num_threads()
    vs.sweep({"box": box}, {"max_resolution": [200, 500, 900]})
    assert len(seen) == 3
    assert all(name.startswith("vecslice-sweep") for name, _, _ in seen)
    assert all(n == 1 for _, n, _ in seen)
    if linux:
        assert all(p == min(19, base + sweeps.HELPER_NICE) for _, _, p in seen)
        assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) == base
    assert numba.get_num_threads() == threads


def test_ctrl_c_stops_the_running_tasks_too(box, monkeypatch):
    """Audit s25 sweep D1: Ctrl-C returned at once, but a running task (one mesh
    x one schedule: every combination) went on making all its combinations in
    the background, on both cores."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    import vecslice.sweeps as sw

    made = []
    real = sw._model

    events = list(sw._STOPS.values())

    def model(*args, **kwargs):
        made.append(time.monotonic())
        if len(made) == 1:  # Ctrl-C while the first combination's parts are made
            stops = [e for e in sw._STOPS.values() if e not in events]
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
            # however loaded the machine, go on once the main thread has taken
            # the interrupt and told the tasks to stop (not after a fixed time)
            deadline = time.monotonic() + 30
            while not any(e.is_set() for e in stops) and time.monotonic() < deadline:
                time.sleep(0.01)
        return real(*args, **kwargs)

    monkeypatch.setattr(sw, "_model", model)
    grid = {"max_resolution": [100, 200, 300, 400, 500, 600],
            "max_deviation": [10, 20]}  # 12 combinations, one task
    with pytest.raises(KeyboardInterrupt):
        vs.sweep(box, grid)
    deadline = time.monotonic() + 10
    while (any(t.name.startswith("vecslice-sweep") for t in threading.enumerate())
           and time.monotonic() < deadline):
        time.sleep(0.05)
    assert not any(t.name.startswith("vecslice-sweep") for t in threading.enumerate())
    assert len(made) == 1, len(made)  # the stop is seen before the next begins
    # a later sweep is not stopped by the earlier one's interrupt
    monkeypatch.setattr(sw, "_model", real)
    assert len(vs.sweep(box, {"max_deviation": [10, 20]})) == 2
