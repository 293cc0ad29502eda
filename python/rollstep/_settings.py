"""Settings objects whose attributes are the keys of the YAML configuration files.

Every assignment is checked by the same C++ reader as a configuration file, with the same
messages (a bad value raises RuntimeError naming the key, the value and the valid range).
"""
import json
import math
import numbers
import re

from . import _rollstep

_PLAIN = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")
_YAML_WORDS = {"true", "false", "null", "yes", "no", "on", "off", "~"}


def _emit(value):
    """A Python value as YAML flow text."""
    if isinstance(value, bool) or type(value).__name__ == "bool_":
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        v = float(value)
        if math.isnan(v):
            return ".nan"
        if math.isinf(v):
            return ".inf" if v > 0 else "-.inf"
        return repr(v)
    if isinstance(value, str):
        if _PLAIN.match(value) and value.lower() not in _YAML_WORDS:
            return value
        return json.dumps(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_emit(str(k))}: {_emit(v)}" for k, v in value.items()) + "}"
    if hasattr(value, "tolist"):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_emit(v) for v in value) + "]"
    raise TypeError(f"cannot write a {type(value).__name__} as a setting value")


class _Section:
    """A nested mapping of a settings object (e.g. OcpSettings.solver): reads and writes go
    through its owner, with the owner's checks."""

    def __init__(self, owner, path):
        object.__setattr__(self, "_owner", owner)
        object.__setattr__(self, "_path", tuple(path))

    def _tree(self):
        tree = self._owner.to_dict()
        for key in self._path:
            tree = tree[key]
        return tree

    def __getattr__(self, key):
        tree = self._tree()
        if key not in tree:
            raise AttributeError(f"{'.'.join(self._path)} has no setting '{key}'")
        value = tree[key]
        return _Section(self._owner, self._path + (key,)) if isinstance(value, dict) else value

    def __setattr__(self, key, value):
        update = {key: value}
        for name in reversed(self._path):
            update = {name: update}
        self._owner._update(update)

    def __dir__(self):
        return sorted(self._tree().keys())

    def keys(self):
        """The setting names of this section."""
        return list(self._tree().keys())

    def to_dict(self):
        """This section's settings as a dict."""
        return self._tree()

    def __repr__(self):
        return f"<{'.'.join(self._path)}: {self._tree()}>"


class Settings:
    """Base of the settings classes: attributes are the YAML keys."""

    _cpp_class = None
    _kind = ""

    def __init__(self, **values):
        """Defaults (the documented ones of the configuration file), then `values`."""
        object.__setattr__(self, "_cpp", self._cpp_class())
        if values:
            self._update(values)

    @classmethod
    def _wrap(cls, cpp):
        obj = cls.__new__(cls)
        object.__setattr__(obj, "_cpp", cpp)
        return obj

    @classmethod
    def load(cls, path):
        """Reads a YAML file (any subset of the keys; unknown keys and bad values are errors
        naming the file, line and key)."""
        return cls._wrap(cls._cpp_class.load(str(path)))

    @classmethod
    def from_yaml(cls, text, source="<text>"):
        """Reads YAML text (as load)."""
        return cls._wrap(cls._cpp_class.parse(text, source))

    def to_yaml(self):
        """Every key with its value, as YAML text that load/from_yaml read back exactly."""
        return self._cpp.to_yaml()

    def to_dict(self):
        """Every key with its value (nested mappings as dicts, vectors as numpy arrays)."""
        return self._cpp.to_dict()

    def keys(self):
        """The setting names (the YAML keys), in the file's order."""
        return list(self.to_dict().keys())

    def copy(self):
        """An independent copy."""
        return self._wrap(self._cpp_class(self._cpp))

    def _update(self, values):
        self._cpp.update(_emit(values))

    def __getattr__(self, key):
        if key.startswith("_"):
            raise AttributeError(key)
        tree = self.to_dict()
        if key not in tree:
            raise AttributeError(f"{type(self).__name__} has no setting '{key}'")
        value = tree[key]
        return _Section(self, (key,)) if isinstance(value, dict) else value

    def __setattr__(self, key, value):
        if isinstance(value, Settings):
            value = value.to_dict()
        elif isinstance(value, _Section):
            value = value.to_dict()
        self._update({key: value})

    def __dir__(self):
        return sorted(set(self.keys()) | set(type(self).__dict__) | set(Settings.__dict__))

    def __eq__(self, other):
        return isinstance(other, type(self)) and self.to_yaml() == other.to_yaml()

    def __repr__(self):
        return f"{type(self).__name__}.from_yaml({self.to_yaml()!r})"


class OcpSettings(Settings):
    """Settings of the full-centroidal OCP: weights, gains, limits, horizon and a nested
    `solver` section (the keys of config/ocp.yaml, which documents each one with its unit
    and default). Example: s = OcpSettings(horizon=50); s.dt = 0.02;
    s.solver.max_iterations = 100. A bad value raises RuntimeError with the YAML reader's
    message ("OCP settings OcpSettings: line 1: horizon: ...")."""

    _cpp_class = _rollstep._OcpSettings


class SolverSettings(Settings):
    """Settings of the solver (the keys of config/solver.yaml: mode 'converging' or
    'realtime', tolerances, barrier, line search, threads...). Checked as that file is."""

    _cpp_class = _rollstep._SolverSettings


def _merge(tree, update):
    for key, value in update.items():
        if isinstance(value, dict) and isinstance(tree.get(key), dict):
            _merge(tree[key], value)
        else:
            tree[key] = value


def _to_block(tree, indent=""):
    lines = []
    for key, value in tree.items():
        if isinstance(value, dict):
            lines.append(f"{indent}{key}:")
            lines.append(_to_block(value, indent + "  "))
        else:
            lines.append(f"{indent}{key}: {_emit(value)}")
    return "\n".join(line for line in lines if line)


class ControlSettings(Settings):
    """Settings of the control pipeline (the keys of config/control.yaml: mpc, ocp,
    integrator, cbf... sections), checked as that file is. An assignment re-reads the whole
    settings, so a message's line refers to the settings written out as YAML."""

    _cpp_class = _rollstep._ControlSettings

    def _update(self, values):
        tree = self.to_dict()
        _merge(tree, values)
        cpp = self._cpp_class.parse(_to_block(tree) + "\n", "ControlSettings")
        object.__setattr__(self, "_cpp", cpp)


class RunSpec(Settings):
    """A simulation run, the spec `rollstep sim` runs and writes to DIR/run.yaml: robot,
    scene or scene_file or inline_scene (the scene itself: a dict of a scene file's keys,
    scene then its name), scene_parameters (a dict of the scene's numbers for this run: its
    parameters, friction), controller ('stand', 'drive', 'nmpc', 'cbfqp'), duration [s], gait,
    command (a list of [time s, vx m/s, vy m/s, yaw_rate rad/s] entries, base frame, each from
    its time on), drive_speed and drive_turn_speed [m/s], control_config (a file)
    or control (the control settings inline: a dict of a control file's keys, or None),
    mpc_timing and integrator ('default': the control settings'), terrain ('scene' or
    'perception'), lidar_config, perception_config, perception_timing, state_source
    ('ground_truth' or 'inekf': the state estimator on the plant's sensors),
    estimator_config, sensor_config, out, log_every, map_log, map_log_rate, log_violations.
    Checked as a spec file is (RuntimeError naming the key; keys that apply to another
    controller or terrain only must stay at their defaults). RunSpec.defaults() documents
    every key with its default. Example: RunSpec(scene='step20', controller='nmpc',
    gait='trot', command=[[0, 0.15, 0, 0]], state_source='inekf')."""

    _cpp_class = _rollstep._RunSpec

    @staticmethod
    def defaults():
        """Every key with its default, unit and range (YAML text)."""
        return _rollstep._RunSpec.defaults()

    def to_dict(self):
        """Every key with its value."""
        return _rollstep._yaml_to_python(self.to_yaml())
