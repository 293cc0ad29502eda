"""The robot OCP: bit for bit the C++ API's plan, reading the plan, real-time iterations,
commands and terrains, and two OCPs solving in parallel from two Python threads."""
import threading
import time

import numpy as np
import pytest

import rollstep
from conftest import run_reference


def small_settings(horizon=30):
    return rollstep.OcpSettings(horizon=horizon)


def test_equal_to_cpp_bit_for_bit(tmp_path, robot_dir):
    s = small_settings()
    path = tmp_path / "ocp.yaml"
    path.write_text(s.to_yaml())
    ref = run_reference(["ocp", f"{robot_dir}/centroidal.yaml", str(path), "step20", "trot", "0.2"])
    ocp = rollstep.CentroidalOcp(settings=s, scene="step20", gait="trot", command=(0.2, 0.0, 0.0))
    status = ocp.solve()
    assert status == ref["status"]
    np.testing.assert_array_equal(ocp.states, ref["states"])
    np.testing.assert_array_equal(ocp.inputs, ref["inputs"])
    assert ocp.cost == ref["cost"][0, 0]


def test_plan_reads_consistently():
    ocp = rollstep.CentroidalOcp(settings=small_settings(), gait="trot", command=(0.3, 0.0, 0.0))
    assert ocp.solve() in ("Converged", "Acceptable")
    N, nc, nj = ocp.horizon, ocp.nc, ocp.nj
    assert ocp.states.shape == (N + 1, ocp.nx) and ocp.inputs.shape == (N, ocp.nu)
    np.testing.assert_allclose(np.diff(ocp.times), ocp.dt)
    f = ocp.contact_forces
    assert f.shape == (N, nc, 3)
    np.testing.assert_array_equal(f.reshape(N, -1), ocp.inputs[:, nj:])
    # Swing feet carry no force; stance feet carry the weight together (gravity 9.81).
    modes = ocp.modes[:N]
    for k in range(N):
        for i in range(nc):
            if not (modes[k] >> i) & 1:
                assert np.all(np.abs(f[k, i]) < 1e-6)
    mg = ocp.model.total_mass * 9.81
    assert abs(f[:, :, 2].sum(axis=1).mean() - mg) < 0.1 * mg
    # Feet sit at the nominal wheel centre height in stance at the start.
    p = ocp.foot_positions
    assert p.shape == (N + 1, nc, 3)
    stats = ocp.stats
    assert len(stats["kkt_error"]) == ocp.iterations + 1 or len(stats["kkt_error"]) == ocp.iterations
    assert stats["kkt_error"][-1] <= 1e-6
    groups = {v["group"]: v["value"] for v in ocp.constraint_violations()}
    assert groups["dynamics"] < 1e-8
    # The base moves forward at about the commanded speed.
    assert 0.3 * N * ocp.dt * 0.5 < ocp.states[-1, 0] < 0.3 * N * ocp.dt * 1.5


def test_realtime_iterations_and_commands():
    ocp = rollstep.CentroidalOcp(settings=small_settings(), gait="rolling")
    x0 = ocp.standing_state()
    assert ocp.solve(x0) in ("Converged", "Acceptable")
    assert abs(ocp.base_twists[5, 0]) < 1e-3
    for i in range(5):
        assert ocp.realtime_iteration(0.01 * (i + 1), ocp.states[1]) == "IterationDone"
    assert ocp.times[0] == pytest.approx(0.05)
    ocp.set_command((0.3, 0.0, 0.0))
    ocp.cold_start()
    assert ocp.solve(x0) in ("Converged", "Acceptable")
    assert ocp.base_twists[10, 0] > 0.1  # rolling forward
    ocp.set_command_schedule([[0.0, 0.0, 0.0, 0.0], [0.2, 0.2, 0.0, 0.0]])
    with pytest.raises(ValueError, match="x0 has size 3"):
        ocp.solve(np.zeros(3))


def test_terrain_swap_is_checked():
    ocp = rollstep.CentroidalOcp(settings=small_settings(), scene="step20", gait="trot")
    sc = rollstep.SceneConfig("step20")
    sc.step1_height = 0.1
    ocp.set_terrain(sc)  # same layout, lower step
    assert ocp.solve() in ("Converged", "Acceptable")


def test_two_threads_solve_in_parallel():
    """Each solve releases the GIL: the two threads' solves overlap in time (with the GIL
    held the second could only start when the first has returned), and each thread's plan
    equals the same solve run alone."""
    settings = small_settings(horizon=100)
    commands = [(0.2, 0.0, 0.0), (0.0, 0.1, 0.0)]
    alone = []
    for c in commands:
        ocp = rollstep.CentroidalOcp(settings=settings, gait="trot", command=c)
        ocp.solve()
        alone.append(ocp.states)
    ocps = [rollstep.CentroidalOcp(settings=settings, gait="trot", command=c) for c in commands]
    spans = [None, None]
    barrier = threading.Barrier(2)

    def work(i):
        barrier.wait()
        t0 = time.perf_counter()
        ocps[i].solve()
        spans[i] = (t0, time.perf_counter())

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i in range(2):
        np.testing.assert_array_equal(ocps[i].states, alone[i])
    overlap = min(spans[0][1], spans[1][1]) - max(spans[0][0], spans[1][0])
    shorter = min(s[1] - s[0] for s in spans)
    assert overlap > 0.5 * shorter, (spans, overlap)


def test_gil_released_while_solving():
    """A Python thread keeps running while another solves."""
    ocp = rollstep.CentroidalOcp(settings=small_settings(horizon=100), gait="trot", command=(0.2, 0, 0))
    done = threading.Event()
    worker = threading.Thread(target=lambda: (ocp.solve(), done.set()))
    stamps = []
    worker.start()
    while not done.is_set():
        stamps.append(time.perf_counter())
    worker.join()
    solve_time = ocp.solve_time
    gaps = np.diff(stamps) if len(stamps) > 1 else np.array([solve_time])
    # With the GIL held the loop would stop for the whole solve.
    assert gaps.max() < 0.5 * solve_time + 1e-3 or solve_time < 0.02, (gaps.max(), solve_time)


def test_no_leak_over_many_solves():
    import resource
    ocp = rollstep.CentroidalOcp(settings=small_settings(horizon=20), gait="standing")
    x0 = ocp.standing_state()
    for _ in range(20):
        ocp.realtime_iteration(0.0, x0)
        _ = ocp.states, ocp.inputs, ocp.contact_forces, ocp.stats
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for _ in range(300):
        ocp.realtime_iteration(0.0, x0)
        _ = ocp.states, ocp.inputs, ocp.contact_forces, ocp.stats
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    assert after - before < 8000  # kB
