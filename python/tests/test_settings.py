"""Settings objects: the YAML keys as attributes, the C++ readers' checks and messages."""
import os

import numpy as np
import pytest

import rollstep


def test_defaults_and_names_are_the_yaml_keys():
    s = rollstep.OcpSettings()
    assert s.horizon == 100
    assert s.dt == pytest.approx(0.015)
    np.testing.assert_array_equal(s.base_velocity_weight, [10, 10, 300, 5, 100, 5])
    assert s.solver.exact_hessian is False
    # The NMPC's default behaviour: the speed rule and two iterations per update.
    assert s.speed_adaptation is True
    assert s.solver.realtime_iterations == 2
    # ControlSettings() is what `rollstep sim --controller nmpc` runs without a file, and
    # what config/control.yaml documents.
    c = rollstep.ControlSettings()
    assert c == rollstep.ControlSettings.load(os.path.join(rollstep.config_dir(), "control.yaml"))
    assert c.mpc.latency == pytest.approx(0.02)
    assert "horizon" in dir(s) and "solver" in s.keys()


def test_assignment_round_trips_through_yaml():
    s = rollstep.OcpSettings(horizon=40, dt=0.02)
    s.base_position_weight = [1.0, 2.0, 3.0]
    s.solver.max_iterations = 7
    s.soft_state_constraints = True
    s.friction_coefficient = 0.1 + 0.2  # not a short decimal: must survive exactly
    t = rollstep.OcpSettings.from_yaml(s.to_yaml())
    assert t == s
    assert t.friction_coefficient == 0.1 + 0.2
    assert t.solver.max_iterations == 7
    np.testing.assert_array_equal(t.base_position_weight, [1, 2, 3])


def test_checks_with_the_file_readers_messages():
    s = rollstep.OcpSettings()
    with pytest.raises(RuntimeError, match=r"horizon: 0 is outside \[1, 10000\]"):
        s.horizon = 0
    assert s.horizon == 100  # unchanged
    with pytest.raises(RuntimeError, match="unknown key 'horizn'"):
        s.horizn = 3
    with pytest.raises(RuntimeError, match="kkt_tolerance must be finite and > 0"):
        s.solver.kkt_tolerance = -1.0
    with pytest.raises(RuntimeError, match="base_position_weight"):
        s.base_position_weight = [1.0, 2.0]
    with pytest.raises(AttributeError):
        s.no_such_key  # noqa: B018


def test_load_the_shipped_files():
    import os
    cfg = rollstep.config_dir()
    c = rollstep.ControlSettings.load(os.path.join(cfg, "baseline.yaml"))
    c.mpc.timing = "deterministic"
    assert c.mpc.timing == "deterministic"
    with pytest.raises(RuntimeError):
        c.mpc.timing = "sometimes"
    so = rollstep.SolverSettings(mode="realtime")
    assert so.mode == "realtime"


def test_scene_config_checks():
    sc = rollstep.SceneConfig("step20")
    assert sc.name == "step20"
    sc.step1_height = 0.1
    assert sc.step1_height == 0.1
    with pytest.raises(ValueError, match="step1_height"):
        sc.step1_height = -1.0
    assert sc.step1_height == 0.1
    with pytest.raises(ValueError, match="unknown scene 'moon'"):
        rollstep.SceneConfig("moon")
    assert rollstep.SceneConfig.parse(sc.to_yaml()).step1_height == 0.1
    sc.set("boxes[0].yaw_deg", 30)
    assert sc.get("boxes[0].yaw_deg") == 30
    with pytest.raises(ValueError, match="slope"):
        ramp = rollstep.SceneConfig.parse(
            "ramps:\n  - {position: [2, 0, 0], size: [2, 1, 0.1], slope_deg: 10}\n")
        ramp.set("ramps[0].slope_deg", 25)
