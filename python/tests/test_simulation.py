"""The simulation: the same run as `rollstep sim` (its log.csv, value for value), stepping
with the state readable between steps, the log as numpy columns with units, checks."""
import csv
import os

import numpy as np
import pytest

import rollstep


def test_drive_rolls_forward_and_steps_equal_run():
    a = rollstep.Simulation(scene="flat", controller="drive", speed=0.3)
    a.run(0.6)
    b = rollstep.Simulation(scene="flat", controller="drive", speed=0.3)
    xs = []
    for _ in range(600):
        b.step()
        xs.append(b.state()["base_position"][0])
    assert b.time == pytest.approx(0.6)
    la, lb = a.log(), b.log()
    for name in la:
        np.testing.assert_array_equal(la[name], lb[name], err_msg=name)
    assert np.all(np.diff(xs[300:]) > 0)  # rolling forward once the wheels ramped up
    assert xs[-1] > 0.05
    assert len(la["time"]) == 61  # a row at the start and every 10 periods
    units = a.log_units()
    assert units["base_x"] == "m" and units["time"] == "s" and units["fz_LF"] == "N"
    np.testing.assert_array_equal(a.log(with_units=True)["base_x[m]"], la["base_x"])


def _csv_rows(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


FORMATS = [("time", "%.4f")] + [(n, "%.6f") for n in ("base_x", "base_y", "base_z", "base_qw", "base_qx", "base_qy", "base_qz")] + \
    [(n, "%.5f") for n in ("base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz")]


@pytest.mark.parametrize("controller,scene", [("nmpc", "flat"), ("cbfqp", "step20")])
def test_run_equals_the_command_line_run(tmp_path, controller, scene):
    program = os.environ.get("ROLLSTEP_PROGRAM") or rollstep._paths.PROGRAM
    if not os.path.exists(program):
        pytest.skip("the rollstep program is not built")
    out = tmp_path / "sim"
    timing = ["--mpc-timing", "deterministic"] if controller == "nmpc" else []
    rollstep.run_command(["sim", "--scene", scene, "--controller", controller, "--gait", "trot", "--vx", "0.2",
                          "--duration", "0.4", "--out", str(out)] + timing, capture=True)
    rows = _csv_rows(out / "log.csv")
    header = [rollstep._split_unit(c)[0] for c in rows[0]]
    sim = rollstep.Simulation(scene=scene, controller=controller, gait="trot", command=(0.2, 0.0, 0.0))
    sim.run(0.4)
    log = sim.log()
    assert list(log) == header
    assert len(log["time"]) == len(rows) - 1
    joints = [n for n in header if n.startswith("q_")]
    for name, fmt in FORMATS + [(n, "%.6f") for n in joints]:
        column = header.index(name)
        ours = [fmt % v for v in log[name]]
        theirs = [r[column] for r in rows[1:]]
        assert ours == theirs, name
    # The controller acts: a trot moves the legs (a frozen log would match trivially).
    assert max(np.ptp(log[n]) for n in joints) > 1e-3


def test_state_and_checks():
    sim = rollstep.Simulation(scene="step20", controller="stand")
    s = sim.state()
    assert s["wheel_center"].shape == (6, 3) and s["joint_position"].shape == (12,)
    assert np.all(s["foot_contact"] == 1) or sim.time == 0.0
    sim.run(0.2)
    s = sim.state()
    assert np.all(s["foot_contact"] == 1)
    assert abs(s["foot_force"][:, 2].sum() - 9.81 * rollstep.load_robot_model().total_mass) < 0.1 * 9.81 * rollstep.load_robot_model().total_mass
    with pytest.raises(RuntimeError, match="controller: expected stand, drive, nmpc or cbfqp, got 'fly'"):
        rollstep.Simulation(controller="fly")
    with pytest.raises(ValueError, match="duration"):
        sim.run(-1)
    with pytest.raises(RuntimeError, match=r"drive_speed: 9.0 is outside \[-1.8, 1.8\]"):
        rollstep.Simulation(controller="drive", speed=9.0)


def test_gil_released_while_stepping():
    import threading
    import time
    sim = rollstep.Simulation(scene="flat", controller="drive", speed=0.2)
    done = threading.Event()
    spans = []

    def work():
        t0 = time.perf_counter()
        sim.run(1.0)
        spans.append(time.perf_counter() - t0)
        done.set()

    worker = threading.Thread(target=work)
    stamps = []
    worker.start()
    while not done.is_set():
        stamps.append(time.perf_counter())
    worker.join()
    gaps = np.diff(stamps) if len(stamps) > 1 else np.array([spans[0]])
    # With the GIL held the loop would stop for the whole run.
    assert gaps.max() < 0.5 * spans[0] + 1e-3 or spans[0] < 0.02, (gaps.max(), spans[0])


def test_command_line_entry_points():
    program = os.environ.get("ROLLSTEP_PROGRAM") or rollstep._paths.PROGRAM
    if not os.path.exists(program):
        pytest.skip("the rollstep program is not built")
    for run in (rollstep.run_trials, rollstep.run_report):
        out = run("--help", capture=True)
        assert out.returncode == 0 and "--out" in out.stdout
    import subprocess
    with pytest.raises(subprocess.CalledProcessError):
        rollstep.run_command(["sim", "--scene", "moon"], capture=True)
