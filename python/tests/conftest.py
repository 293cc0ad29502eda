"""Shared helpers of the Python tests (run by ctest: label `python`)."""
import os
import subprocess

import numpy as np
import pytest

import rollstep


def run_reference(args, stdin=""):
    """Runs the C++ reference program; returns {name: array} (bit-exact hex floats)."""
    exe = os.environ.get("ROLLSTEP_REFERENCE")
    if not exe:
        pytest.skip("ROLLSTEP_REFERENCE not set (run through ctest)")
    out = subprocess.run([exe] + list(args), input=stdin, capture_output=True, text=True, check=True)
    result = {}
    for line in out.stdout.splitlines():
        words = line.split()
        if words[0] == "status":
            result["status"] = " ".join(words[1:])
            continue
        rows, cols = int(words[1]), int(words[2])
        values = [float.fromhex(w) for w in words[3:]]
        result[words[0]] = np.array(values).reshape((cols, rows)).T
    return result


def hex_line(tag, v):
    return tag + " " + " ".join(float(x).hex() for x in v) + "\n"


@pytest.fixture(scope="session")
def robot_dir():
    return rollstep.default_robot()


@pytest.fixture(scope="session")
def model():
    return rollstep.load_robot_model()


def random_configuration(model, rng):
    """A random configuration (unit quaternion, joints within their limits) and velocity."""
    q = rollstep.neutral_configuration(model)
    q[:3] = rng.normal(size=3) * 0.3
    quat = rng.normal(size=4)
    q[3:7] = quat / np.linalg.norm(quat)
    lo, hi = model.lower_position_limit, model.upper_position_limit
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)
    q[7:] = lo + (hi - lo) * rng.uniform(size=model.nj)
    v = rng.normal(size=model.nv)
    return q, v
