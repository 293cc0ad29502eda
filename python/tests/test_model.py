"""The model bindings: the C++ API's results bit for bit, derivatives against finite
differences, input checks."""
import numpy as np
import pytest

import rollstep
from conftest import hex_line, random_configuration, run_reference


def test_load_robot_model(model):
    assert model.nq == 7 + model.nj and model.nv == 6 + model.nj
    assert model.nj == 12
    assert model.has_free_flyer
    assert "LF_wheel" in model.frame_names
    assert model.total_mass > 0
    assert model.get_frame_id("LF_wheel") == model.frame_names.index("LF_wheel")


def test_equal_to_cpp_bit_for_bit(model, robot_dir):
    rng = np.random.default_rng(3)
    q, v = random_configuration(model, rng)
    ref = run_reference(["model", f"{robot_dir}/tachyon3.urdf"], hex_line("q", q) + hex_line("v", v))
    d = rollstep.Data(model)
    rollstep.forward_kinematics(model, d, q, v)
    rollstep.update_frame_placements(model, d)
    T = rollstep.get_frame_placement(model, d, "LF_wheel")
    f = model.get_frame_id("LF_wheel")
    np.testing.assert_array_equal(d.opf[f], ref["placement_p"][:, 0])
    all_frames = d.oRf
    d2 = rollstep.Data(model)
    rollstep.forward_kinematics(model, d2, q)
    rollstep.update_frame_placement(model, d2, f)
    np.testing.assert_array_equal(d2.oRf[f], all_frames[f])
    np.testing.assert_array_equal(T[:3, :3], ref["placement_R"])
    np.testing.assert_array_equal(T[:3, 3], ref["placement_p"][:, 0])
    vel = rollstep.get_frame_velocity(model, d, "LF_wheel", rollstep.ReferenceFrame.LOCAL)
    np.testing.assert_array_equal(vel, ref["velocity_local"][:, 0])
    rollstep.compute_joint_jacobians(model, d, q)
    J = rollstep.get_frame_jacobian(model, d, "LF_wheel", rollstep.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    np.testing.assert_array_equal(J, ref["jacobian_lwa"])
    np.testing.assert_array_equal(rollstep.center_of_mass(model, d, q), ref["com"][:, 0])
    np.testing.assert_array_equal(rollstep.jacobian_center_of_mass(model, d, q), ref["Jcom"])
    np.testing.assert_array_equal(rollstep.compute_centroidal_momentum(model, d, q, v), ref["hg"][:, 0])
    dh_dq, dh_dv = rollstep.compute_centroidal_momentum_derivatives(model, d, q, v)
    np.testing.assert_array_equal(dh_dq, ref["dhg_dq"])
    np.testing.assert_array_equal(dh_dv, ref["Ag"])
    np.testing.assert_array_equal(d.dhg_dq, ref["dhg_dq"])  # the workspace view
    np.testing.assert_array_equal(rollstep.compute_generalized_gravity(model, d, q), ref["g"][:, 0])
    np.testing.assert_array_equal(rollstep.compute_generalized_gravity_derivatives(model, d, q), ref["dg_dq"])
    np.testing.assert_array_equal(rollstep.integrate(model, q, v), ref["integrate"][:, 0])


def test_centroidal_momentum_derivative_by_finite_differences(model):
    rng = np.random.default_rng(7)
    q, v = random_configuration(model, rng)
    d = rollstep.Data(model)
    dh_dq, dh_dv = rollstep.compute_centroidal_momentum_derivatives(model, d, q, v)
    eps = 1e-6
    fd = np.zeros_like(dh_dq)
    for i in range(model.nv):
        e = np.zeros(model.nv)
        e[i] = eps
        hp = rollstep.compute_centroidal_momentum(model, d, rollstep.integrate(model, q, e), v)
        hm = rollstep.compute_centroidal_momentum(model, d, rollstep.integrate(model, q, -e), v)
        fd[:, i] = (hp - hm) / (2 * eps)
    scale = max(1.0, np.abs(dh_dq).max())
    assert np.abs(fd - dh_dq).max() < 1e-6 * scale
    # A wrong derivative would fail: the momentum depends on q.
    assert np.abs(dh_dq).max() > 1e-3
    np.testing.assert_allclose(dh_dv @ v, rollstep.compute_centroidal_momentum(model, d, q, v), atol=1e-12)


def test_frame_position_derivative_by_finite_differences(model):
    rng = np.random.default_rng(11)
    q, v = random_configuration(model, rng)
    d = rollstep.Data(model)
    rollstep.compute_forward_kinematics_derivatives(model, d, q, v)
    dp = rollstep.get_frame_position_derivative(model, d, "RR_wheel")
    eps = 1e-6

    def position(qq):
        rollstep.forward_kinematics(model, d, qq)
        return rollstep.get_frame_placement(model, d, "RR_wheel")[:3, 3]

    fd = np.column_stack([
        (position(rollstep.integrate(model, q, eps * e)) - position(rollstep.integrate(model, q, -eps * e))) / (2 * eps)
        for e in np.eye(model.nv)
    ])
    assert np.abs(fd - dp).max() < 1e-7


def test_size_and_name_checks(model):
    d = rollstep.Data(model)
    with pytest.raises(ValueError, match="q has size 3; expected 19"):
        rollstep.center_of_mass(model, d, np.zeros(3))
    with pytest.raises(IndexError, match="has no frame 'nope'"):
        rollstep.get_frame_placement(model, d, "nope")
    with pytest.raises(IndexError, match="frame index"):
        rollstep.get_frame_placement(model, d, 10000)


def test_no_leak_over_many_calls(model):
    import resource
    d = rollstep.Data(model)
    q = rollstep.neutral_configuration(model)
    v = np.zeros(model.nv)

    def burst():
        for _ in range(2000):
            rollstep.compute_centroidal_momentum_derivatives(model, d, q, v)
            rollstep.get_frame_jacobian(model, d, 3)

    burst()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for _ in range(5):
        burst()
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # 10000 calls returning (6, 18) arrays: a leak of each would be > 10 MB.
    assert after - before < 8000  # kB


def test_docstrings_say_units_and_frames():
    for name in ["get_frame_jacobian", "compute_centroidal_momentum", "get_frame_placement",
                 "center_of_mass", "compute_generalized_gravity"]:
        doc = getattr(rollstep, name).__doc__
        assert "world" in doc.lower() or "frame" in doc.lower(), name
    assert "[m]" in rollstep.center_of_mass.__doc__


def test_paths_as_pathlib(robot_dir):
    import pathlib
    m = rollstep.build_model_from_urdf(pathlib.Path(robot_dir) / "tachyon3.urdf")
    assert m.nq == 19
    assert rollstep.load_robot_model(pathlib.Path(robot_dir)).nq == 19
