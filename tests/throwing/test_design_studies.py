"""Design studies that scale (issue 14 item 5): batched rows, robustness on a Dask cluster, limits."""

import math

import numpy as np
import pytest
from throwing_helpers import TRIANGLE_PARAMS, triangle

from feeder_planner.errors import InputError
from feeder_planner.throwing.design import MAX_DESIGNS, Design, evaluate, search
from feeder_planner.throwing.studies import robust_study
from feeder_planner.throwing.throw_map import ThrowParams, throw_batch, throw_rows

G, MU = -9.66, 0.5


def test_rows_with_their_own_design_equal_one_design_batches():
    part = triangle()
    rng = np.random.default_rng(1)
    edges = rng.choice(part.stable_edges, 60)
    radii = rng.uniform(0.08, 0.16, 60)
    h = rng.choice([-0.006, -0.004, -0.002], 60)
    w = rng.choice([math.radians(300), math.radians(340)], 60)
    mixed = throw_rows(part, edges, radii, h, w, G, MU)
    for hv in np.unique(h):
        for wv in np.unique(w):
            rows = np.flatnonzero((h == hv) & (w == wv))
            alone = throw_batch(part, edges[rows], radii[rows], ThrowParams(float(hv), float(wv), G, MU))
            np.testing.assert_array_equal(mixed.edge[rows], alone.edge)
            np.testing.assert_array_equal(mixed.radius[rows], alone.radius)
            np.testing.assert_array_equal(mixed.flag("slip")[rows], alone.flag("slip"))


def test_a_designs_row_does_not_depend_on_its_batch():
    part = triangle()
    designs = [Design(-0.005, math.radians(320), MU), Design(-0.002, math.radians(280), 0.4)]
    together = evaluate(part, 1, designs, G, 0.001)
    apart = [evaluate(part, 1, [d], G, 0.001)[0] for d in designs]
    assert together == apart
    assert together[0].unique and together[0].cycle == [1, 0, 2] and together[0].trigger is not None


def test_search_reports_progress_and_refuses_too_many_designs():
    part = triangle()
    seen = []
    found = search(
        part,
        1,
        np.array([-0.005, -0.003]),
        np.array([TRIANGLE_PARAMS.speed]),
        G,
        MU,
        progress=lambda done, total: seen.append((done, total)),
    )
    assert seen[-1] == (2, 2) and found.best is not None and found.best.unique
    many = np.linspace(-0.008, -0.001, MAX_DESIGNS // 10 + 1)
    with pytest.raises(InputError) as info:
        search(part, 1, many, np.linspace(4.0, 6.0, 10), G, MU)
    assert info.value.field == "offsets" and str(MAX_DESIGNS) in str(info.value)


def test_robust_study_on_two_dask_workers_equals_one_process():
    part = triangle()
    # h = -1.4 cm is near -d_min (-1.49 cm): large sigmas there break the design for some samples.
    args = (part, 1, np.array([-0.014, -0.002]), np.array([math.radians(260)]), G, MU, 3, 0.2, 0.3, 0.3)
    alone = robust_study(*args, seed=11, sensing_height=0.001)
    cluster = robust_study(*args, seed=11, sensing_height=0.001, workers=2)
    assert cluster.points == alone.points and cluster.workers == 2
    # Large sigmas: some perturbed designs lose the unique limit set or the trigger range.
    assert 0 < alone.points[0].unique < 1 and 0 < alone.points[0].trigger < 1 and alone.points[0].invalid
    assert alone.points[1].unique == 1.0
    with pytest.raises(InputError) as info:
        robust_study(*args[:7], 1.5, 0.1, 0.1)
    assert info.value.field == "speed_sigma"


def _distributed_log_level() -> int:
    import logging

    return logging.getLogger("distributed").getEffectiveLevel()


def test_a_local_clusters_workers_log_only_critical_messages():
    """Their shutdown (a heartbeat to a closed scheduler) must not print a traceback after Ctrl-C."""
    import logging

    from feeder_planner.dask_cluster import dask_client

    with dask_client(2, None) as client:
        levels = client.run(_distributed_log_level)
    assert len(levels) == 2 and set(levels.values()) == {logging.CRITICAL}, levels


def test_ctrl_c_inside_a_local_cluster_silences_its_shutdown_in_this_process():
    """The scheduler runs here: its reports of workers removed mid-task must not follow the one line."""
    import logging

    from feeder_planner.dask_cluster import SHUTDOWN_LOGGERS, dask_client

    before = {name: logging.getLogger(name).level for name in SHUTDOWN_LOGGERS}
    try:
        with pytest.raises(KeyboardInterrupt), dask_client(1, None):
            raise KeyboardInterrupt
        levels = {name: logging.getLogger(name).getEffectiveLevel() for name in SHUTDOWN_LOGGERS}
        assert all(level > logging.CRITICAL for level in levels.values()), levels
    finally:
        for name, level in before.items():
            logging.getLogger(name).setLevel(level)
