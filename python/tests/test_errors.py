"""Every C++ error reaches Python as an exception with the C++ message, word for word."""
import os
import subprocess

import pytest

import rollstep


def cpp_message(kind, path):
    exe = os.environ.get("ROLLSTEP_REFERENCE")
    if not exe:
        pytest.skip("ROLLSTEP_REFERENCE not set (run through ctest)")
    out = subprocess.run([exe, "error", kind, str(path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_urdf_errors(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="r"><link name="a"><inertial><mass value="-1"/>'
                   '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>')
    with pytest.raises(rollstep.ModelError) as e:
        rollstep.build_model_from_urdf(str(bad))
    assert str(e.value) == cpp_message("urdf", bad)
    assert isinstance(e.value, RuntimeError)
    missing = tmp_path / "missing.urdf"
    with pytest.raises(RuntimeError) as e:
        rollstep.build_model_from_urdf(str(missing))
    assert str(e.value) == cpp_message("urdf", missing)


def test_settings_file_errors(tmp_path):
    bad = tmp_path / "ocp.yaml"
    bad.write_text("horizon: 20\ndt: -1\n")
    with pytest.raises(RuntimeError) as e:
        rollstep.OcpSettings.load(str(bad))
    assert str(e.value) == cpp_message("ocp_settings", bad)
    assert "line 2" in str(e.value) and "dt" in str(e.value)
    broken = tmp_path / "broken.yaml"
    broken.write_text("horizon: [1, 2\n")
    with pytest.raises(RuntimeError) as e:
        rollstep.OcpSettings.load(str(broken))
    assert str(e.value) == cpp_message("ocp_settings", broken)


def test_scene_and_robot_errors(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text("kind: step20\nfriction: -3\n")
    with pytest.raises(Exception) as e:
        rollstep.SceneConfig.load(str(scene))
    assert str(e.value) == cpp_message("scene", scene)
    robot = tmp_path / "centroidal.yaml"
    robot.write_text("urdf: nowhere.urdf\ncontact_frames: [a]\n")
    with pytest.raises(Exception) as e:
        rollstep.CentroidalOcp(robot=str(robot))
    assert str(e.value) == cpp_message("robot", robot)


def test_exception_classes():
    assert issubclass(rollstep.ModelError, RuntimeError)
    assert issubclass(rollstep.SimError, RuntimeError)
    assert issubclass(rollstep.InputError, RuntimeError)
    with pytest.raises(ValueError, match="unknown scene"):
        rollstep.CentroidalOcp(scene="moon")
    with pytest.raises(ValueError, match="trot"):
        rollstep.CentroidalOcp(gait="gallop", settings=rollstep.OcpSettings(horizon=10))


def _described(doc, name):
    """A docstring that says more than pybind11's generated signature line."""
    lines = [line for line in (doc or "").strip().splitlines() if line.strip()]
    if lines and lines[0].startswith(name + "("):
        lines = lines[1:]
    return len(" ".join(lines)) > 10


def test_every_public_name_is_documented():
    undocumented = []
    for name in rollstep.__all__:
        obj = getattr(rollstep, name)
        if not (callable(obj) or isinstance(obj, type)):
            continue
        if not _described(obj.__doc__, name):
            undocumented.append(name)
        if not isinstance(obj, type) or issubclass(obj, BaseException):
            continue
        for attr in dir(obj):
            if attr.startswith("_") or attr in ("name", "value") and hasattr(obj, "__members__"):
                continue
            member = getattr(obj, attr)
            if isinstance(member, type(rollstep.ReferenceFrame.LOCAL)):
                continue  # enum values
            if callable(member) or isinstance(getattr(type(obj), attr, None), property) or \
                    isinstance(vars(obj).get(attr), property):
                if not _described(member.__doc__, attr):
                    undocumented.append(f"{name}.{attr}")
    assert not undocumented, undocumented
