"""The run spec from Python: the same keys and checks as a spec file, and a Simulation of a
spec (with the state estimator, with perception in closed loop) that gives `rollstep sim
--spec`'s log.csv value for value."""
import csv
import os

import numpy as np
import pytest

import rollstep


def test_spec_keys_checks_and_round_trip(tmp_path):
    spec = rollstep.RunSpec(scene="step20", controller="nmpc", gait="trot",
                            command=[[0, 0.15, 0, 0], [3, 0, 0, 0.2]], duration=5,
                            state_source="inekf")
    assert spec.controller == "nmpc" and spec.duration == 5 and spec.state_source == "inekf"
    np.testing.assert_array_equal(spec.command[1], [3, 0, 0, 0.2])
    back = rollstep.RunSpec.from_yaml(spec.to_yaml())
    assert back == spec
    path = tmp_path / "run.yaml"
    path.write_text(spec.to_yaml())
    # A relative path in a file is relative to the file's folder.
    assert rollstep.RunSpec.load(path).out == str(tmp_path / "out" / "sim")
    spec.out = str(tmp_path / "o")
    path.write_text(spec.to_yaml())
    assert rollstep.RunSpec.load(path) == spec
    assert "duration: 10  # [s] [0.001, 3600]" in rollstep.RunSpec.defaults()
    # The file's checks, with the file's messages.
    with pytest.raises(RuntimeError, match="controller: expected stand, drive, nmpc or cbfqp, got 'fly'"):
        rollstep.RunSpec(controller="fly")
    with pytest.raises(RuntimeError, match="gait: is used only by the nmpc and cbfqp controllers"):
        rollstep.RunSpec(gait="trot")
    with pytest.raises(RuntimeError, match="unknown key 'speed'"):
        rollstep.RunSpec(speed=1)
    with pytest.raises(RuntimeError, match=r"command: entry 1: time 6 s is not before the run's end"):
        rollstep.RunSpec(controller="nmpc", duration=5, command=[[0, 0.1], [6, 0]])
    spec.duration = 4  # an assignment is checked, the spec unchanged when refused
    with pytest.raises(RuntimeError, match="duration: -1 is outside"):
        spec.duration = -1
    assert spec.duration == 4


def _log_rows(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


def _is_number(cell):
    try:
        float(cell)
        return True
    except ValueError:
        return False


def _printed(value, like):
    """`value` printed as the cell `like` of log.csv was: %.Nf or %.Ne."""
    if like in ("nan", "-nan"):
        return like if np.isnan(value) else repr(value)
    mantissa = like.lower().split("e")[0]
    decimals = len(mantissa.split(".", 1)[1]) if "." in mantissa else 0
    return f"{value:.{decimals}{'e' if 'e' in like.lower() else 'f'}}"


def _same_as_command_line(tmp_path, spec):
    program = os.environ.get("ROLLSTEP_PROGRAM") or rollstep._paths.PROGRAM
    if not os.path.exists(program):
        pytest.skip("the rollstep program is not built")
    spec.out = str(tmp_path / "sim")
    spec_file = tmp_path / "spec.yaml"
    spec_file.write_text(spec.to_yaml())
    rollstep.run_command(["sim", "--spec", str(spec_file)], capture=True)
    # The run wrote the spec it ran: the same run.
    assert rollstep.RunSpec.load(tmp_path / "sim" / "run.yaml") == spec
    rows = _log_rows(tmp_path / "sim" / "log.csv")
    sim = rollstep.Simulation(spec=spec)
    sim.run(spec.duration)
    log = sim.log(with_units=True)
    assert list(log) == rows[0]
    assert len(rows) - 1 == len(log["time[s]"])
    compared = 0
    for column, name in enumerate(rows[0]):
        theirs = [row[column] for row in rows[1:]]
        if "[" not in name:  # a column of words (the QP status): the same words
            assert list(log[name]) == theirs, name
            continue
        assert [_printed(v, cell) for v, cell in zip(log[name], theirs)] == theirs, name
        compared += 1
    assert compared > 60
    return log


def test_simulation_with_the_estimator_equals_the_command_line(tmp_path):
    spec = rollstep.RunSpec(scene="flat", controller="nmpc", gait="trot",
                            command=[[0, 0.2, 0, 0]], duration=0.3, mpc_timing="deterministic",
                            state_source="inekf")
    log = _same_as_command_line(tmp_path, spec)
    # The estimator runs on noisy sensors: the controller's state is not the ground truth.
    assert "state inekf" in rollstep.Simulation(spec=spec)._sim.controller_text
    assert max(np.ptp(log[n]) for n in log if n.startswith("q_")) > 1e-3


@pytest.mark.parametrize("controller", ["nmpc", "cbfqp"])
def test_simulation_with_perception_equals_the_command_line(tmp_path, controller):
    spec = rollstep.RunSpec(scene="step20", controller=controller, gait="trot",
                            command=[[0, 0.15, 0, 0]], duration=0.3, terrain="perception")
    if controller == "nmpc":
        spec.mpc_timing = "deterministic"  # perception then runs deterministic as well
    sim = rollstep.Simulation(spec=spec)
    assert "perception in closed loop" in sim._sim.controller_text
    _same_as_command_line(tmp_path, spec)


def _rerun_saved_spec(tmp_path, spec):
    """Runs `spec` in a Simulation, saves its spec and runs that with `rollstep sim --spec`:
    the saved spec reads back equal, the command line's log equals the Simulation's, and the
    run writes the same spec (what was given in code inline). Returns the Simulation."""
    spec.out = str(tmp_path / "sim")
    sim = rollstep.Simulation(spec=spec)
    sim.run(spec.duration)
    sim.save_spec(tmp_path / "run.yaml")
    assert rollstep.RunSpec.load(tmp_path / "run.yaml") == spec
    rollstep.run_command(["sim", "--spec", str(tmp_path / "run.yaml")], capture=True)
    rows = _log_rows(tmp_path / "sim" / "log.csv")
    log = sim.log(with_units=True)
    assert len(rows) - 1 == len(log["time[s]"])
    for column, name in enumerate(rows[0]):
        if "[" in name:
            theirs = [row[column] for row in rows[1:]]
            assert [_printed(v, cell) for v, cell in zip(log[name], theirs)] == theirs, name
    assert rollstep.RunSpec.load(tmp_path / "sim" / "run.yaml") == spec
    return sim


def test_simulation_with_control_settings_given_in_code_writes_a_spec_that_reruns_it(tmp_path):
    """Settings given in code are the spec's own control: section: the spec the Simulation
    saves runs the same with `rollstep sim --spec`, and reads back equal."""
    program = os.environ.get("ROLLSTEP_PROGRAM") or rollstep._paths.PROGRAM
    if not os.path.exists(program):
        pytest.skip("the rollstep program is not built")
    control = rollstep.ControlSettings()
    control.mpc.period = 0.04
    control.feedback.foot_kp = 300
    sim = rollstep.Simulation(scene="step20", controller="nmpc", gait="trot",
                              command=(0.15, 0, 0), control=control, log_every=5)
    assert sim.spec.control.mpc.period == 0.04
    assert sim.spec.control.feedback.foot_kp == 300
    spec = sim.spec
    spec.duration = 0.3
    sim = _rerun_saved_spec(tmp_path, spec)
    # The settings differ from the defaults: a run without them logs differently.
    default = rollstep.Simulation(scene="step20", controller="nmpc", gait="trot",
                                  command=(0.15, 0, 0), log_every=5)
    default.run(0.3)
    assert not np.array_equal(default.log()["base_x"], sim.log()["base_x"])


def test_simulation_with_a_scene_given_in_code_writes_a_spec_that_reruns_it(tmp_path):
    """A scene given in code (a SceneConfig) is the spec's inline_scene, `scene` its name: the
    spec the Simulation saves runs on the same terrain with `rollstep sim --spec` (the same
    log), reads back equal, and a spec file's errors name the inline scene's keys."""
    program = os.environ.get("ROLLSTEP_PROGRAM") or rollstep._paths.PROGRAM
    if not os.path.exists(program):
        pytest.skip("the rollstep program is not built")
    scene = rollstep.SceneConfig("flat")
    scene.set("friction", 0.05)  # the wheels slip under the drive's 1 m/s^2 ramp
    sim = rollstep.Simulation(scene=scene, controller="drive", speed=0.5, log_every=5)
    spec = sim.spec
    assert spec.scene == "flat"
    assert spec.to_dict()["inline_scene"]["friction"] == 0.05
    spec.duration = 0.6
    sim = _rerun_saved_spec(tmp_path, spec)
    # The scene's file (friction 0.8) is not what ran: there the robot gets further.
    on_file = rollstep.Simulation(scene="flat", controller="drive", speed=0.5, log_every=5)
    on_file.run(0.6)
    assert on_file.log()["base_x"][-1] - sim.log()["base_x"][-1] > 0.02
    # The inline scene's keys are checked as a scene file's, named under inline_scene.
    text = spec.to_yaml().replace("friction: 0.05", "friction: [1]")
    with pytest.raises(RuntimeError, match=r"line \d+: inline_scene\.friction"):
        rollstep.RunSpec.from_yaml(text)
    with pytest.raises(RuntimeError, match="inline_scene: and scene_file exclude each other"):
        rollstep.RunSpec.from_yaml(spec.to_yaml().replace('scene_file: ""', "scene_file: a.yaml"))
