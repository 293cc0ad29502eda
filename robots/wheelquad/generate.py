#!/usr/bin/env python3
"""Writes wheelquad.urdf and wheelquad.xml from the geometry and masses below.

Plain Python 3, no packages.

Every mass property comes from simple solids (boxes, solid cylinders) and the parallel
axis theorem, so that the URDF (control model) and the MJCF (MuJoCo plant) carry the same
numbers and anyone can change a dimension and regenerate both:

    python3 robots/wheelquad/generate.py          # rewrite both files
    python3 robots/wheelquad/generate.py --check  # exit 1 if they differ from the files
    python3 robots/wheelquad/generate.py --table  # print the mass table of wheelquad.md

Frames: x forward, y left, z up; the base frame at the body box's centre.
"""
import argparse
import math
import os
import sys


# --- geometry [m] ---------------------------------------------------------------------
BODY_SIZE = (0.70, 0.30, 0.16)      # body box (x, y, z)
HAA_X, HAA_Y = 0.30, 0.08           # hip abduction axes at (+-HAA_X, +-HAA_Y, 0)
HIP_OFFSET = 0.12                   # abduction axis to flexion joint, outward along y
THIGH = 0.30                        # flexion axis to knee axis
SHANK = 0.30                        # knee axis to wheel axle
WHEEL_RADIUS = 0.085
WHEEL_WIDTH = 0.05
# --- nominal posture [rad] --------------------------------------------------------------
NOMINAL = (0.0, 0.8, -1.6)          # (abduction, flexion, knee): wheel below the hip
# The wheel frame is turned about the axle by -(flexion + knee) at the nominal posture, so
# that it is level there (its x forward, z up, as the base's).
WHEEL_MOUNT_PITCH = -(NOMINAL[1] + NOMINAL[2])

# --- masses [kg] and solids ---------------------------------------------------------------
BASE_MASS = 28.0                    # body box: frame, batteries, computers, abduction motors
HIP_MASS = 1.6                      # flexion motor + abduction output: cylinder about y
HIP_CYL = (0.05, 0.10)              # (radius, length) centred 0.07 m outward of the HAA axis
KNEE_MOTOR_MASS = 1.0               # knee motor at the flexion axis: cylinder about y
KNEE_MOTOR_CYL = (0.045, 0.06)
THIGH_TUBE_MASS = 1.2               # thigh tube, box along -z
THIGH_TUBE = (0.05, 0.04, THIGH)
SHANK_MASS = 0.6                    # shank tube with the belt to the knee, box along -z
SHANK_TUBE = (0.03, 0.03, SHANK)
WHEEL_MASS = 1.5                    # in-wheel motor and tyre: solid cylinder about y

# --- joints: (lower, upper) [rad], velocity [rad/s], effort [N m] ------------------------
HAA_LIMITS = (-0.6, 0.6, 12.0, 100.0)
HFE_LIMITS = (-1.0, 2.5, 12.0, 100.0)
KFE_LIMITS = (-2.6, -0.5, 12.0, 150.0)
# Position servos (MuJoCo position actuators; kd as joint damping, integrated implicitly).
SERVO_KP = 1500.0                   # [N m/rad]
SERVO_KD = 30.0                     # [N m s/rad]
# Drive wheels: velocity servos.
WHEEL_KV = 20.0                     # [N m s/rad]
WHEEL_EFFORT = 20.0                 # [N m]
WHEEL_SPEED = 30.0                  # [rad/s] (2.55 m/s at the wheel radius)
WHEEL_ARMATURE = 0.03               # [kg m^2] reflected inertia of a geared in-wheel motor

LEGS = (("LF", 1, 1), ("RF", 1, -1), ("LH", -1, 1), ("RH", -1, -1))  # name, x sign, y sign


def diag(values):
    return [[values[r] if r == c else 0.0 for c in range(3)] for r in range(3)]


def diagonal_of(matrix):
    return [matrix[k][k] for k in range(3)]


def box_inertia(m, size):
    x, y, z = size
    return diag([m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12])


def cylinder_y_inertia(m, radius, length):
    """Solid cylinder whose axis is y."""
    t = m * (3 * radius * radius + length * length) / 12
    return diag([t, m * radius * radius / 2, t])


def combine(parts):
    """(mass, com, inertia about com) of solids given as (mass, centre, inertia about centre):
    the parallel axis theorem, I = sum I_k + m_k (|d_k|^2 E - d_k d_k^T)."""
    mass = sum(m for m, _, _ in parts)
    com = [sum(m * c[k] for m, c, _ in parts) / mass for k in range(3)]
    inertia = [[0.0] * 3 for _ in range(3)]
    for m, c, i in parts:
        d = [c[k] - com[k] for k in range(3)]
        dd = sum(v * v for v in d)
        for r in range(3):
            for col in range(3):
                inertia[r][col] += i[r][col] + m * ((dd if r == col else 0.0) - d[r] * d[col])
    return mass, com, inertia


def bodies(y_sign):
    """Mass properties of one leg's bodies in their own frames (y mirrored for right legs)."""
    hip = combine([(HIP_MASS, (0, y_sign * 0.07, 0), cylinder_y_inertia(HIP_MASS, *HIP_CYL))])
    thigh = combine([
        (KNEE_MOTOR_MASS, (0, 0, 0), cylinder_y_inertia(KNEE_MOTOR_MASS, *KNEE_MOTOR_CYL)),
        (THIGH_TUBE_MASS, (0, 0, -THIGH / 2), box_inertia(THIGH_TUBE_MASS, THIGH_TUBE)),
    ])
    shank = combine([(SHANK_MASS, (0, 0, -SHANK / 2), box_inertia(SHANK_MASS, SHANK_TUBE))])
    wheel = combine([(WHEEL_MASS, (0, 0, 0),
                      cylinder_y_inertia(WHEEL_MASS, WHEEL_RADIUS, WHEEL_WIDTH))])
    return {"hip": hip, "thigh": thigh, "shank": shank, "wheel": wheel}


BASE = combine([(BASE_MASS, (0, 0, 0), box_inertia(BASE_MASS, BODY_SIZE))])


def n(v):
    """12 significant digits, no trailing zeros (both files get the same text)."""
    v = float(v)
    return "0" if v == 0 else "%.12g" % v


def vec(values):
    return " ".join(n(v) for v in values)


def check_diagonal(name, inertia):
    off = max(abs(inertia[r][c]) for r in range(3) for c in range(3) if r != c)
    if off > 1e-15:
        sys.exit("%s: inertia is not diagonal in its frame:\n%s" % (name, inertia))


def urdf_inertial(mass, com, inertia, indent):
    p = " " * indent
    return (f"{p}<inertial>\n"
            f"{p}  <origin xyz=\"{vec(com)}\" rpy=\"0 0 0\"/>\n"
            f"{p}  <mass value=\"{n(mass)}\"/>\n"
            f"{p}  <inertia ixx=\"{n(inertia[0][0])}\" ixy=\"0\" ixz=\"0\" "
            f"iyy=\"{n(inertia[1][1])}\" iyz=\"0\" izz=\"{n(inertia[2][2])}\"/>\n"
            f"{p}</inertial>\n")


def urdf_limit(limits):
    lo, hi, vel, eff = limits
    return f"<limit lower=\"{n(lo)}\" upper=\"{n(hi)}\" velocity=\"{n(vel)}\" effort=\"{n(eff)}\"/>"


def make_urdf():
    out = ["<?xml version=\"1.0\"?>\n",
           "<!-- wheelquad, control model (robots/wheelquad/wheelquad.md). GENERATED by\n"
           "     generate.py in this folder from boxes and cylinders: edit that, not this.\n"
           "     Floating base; per leg a revolute hip abduction (HAA, about base +x), hip\n"
           "     flexion (HFE, +y) and knee (KFE, +y); a drive wheel fixed to the shank (its\n"
           "     inertia counts; it rolls in contact, it is not a model joint).\n"
           "     Frames: <leg>_wheel = wheel centre, level at the nominal posture; <leg>_contact\n"
           "     = ground contact point at the nominal posture (wheel radius below the centre). -->\n",
           "<robot name=\"wheelquad\">\n",
           "  <link name=\"base\">\n",
           urdf_inertial(*BASE, 4),
           f"    <visual><geometry><box size=\"{vec(BODY_SIZE)}\"/></geometry></visual>\n",
           f"    <collision><geometry><box size=\"{vec(BODY_SIZE)}\"/></geometry></collision>\n",
           "  </link>\n"]
    for leg, xs, ys in LEGS:
        b = bodies(ys)
        for part in b:
            check_diagonal(f"{leg}_{part}", b[part][2])
        out.append(f"  <!-- {leg} -->\n")
        out.append(f"  <joint name=\"{leg}_HAA\" type=\"revolute\">\n"
                   f"    <parent link=\"base\"/><child link=\"{leg}_hip\"/>\n"
                   f"    <origin xyz=\"{vec((xs * HAA_X, ys * HAA_Y, 0))}\" rpy=\"0 0 0\"/>\n"
                   f"    <axis xyz=\"1 0 0\"/>\n    {urdf_limit(HAA_LIMITS)}\n  </joint>\n")
        out.append(f"  <link name=\"{leg}_hip\">\n{urdf_inertial(*b['hip'], 4)}  </link>\n")
        out.append(f"  <joint name=\"{leg}_HFE\" type=\"revolute\">\n"
                   f"    <parent link=\"{leg}_hip\"/><child link=\"{leg}_thigh\"/>\n"
                   f"    <origin xyz=\"{vec((0, ys * HIP_OFFSET, 0))}\" rpy=\"0 0 0\"/>\n"
                   f"    <axis xyz=\"0 1 0\"/>\n    {urdf_limit(HFE_LIMITS)}\n  </joint>\n")
        out.append(f"  <link name=\"{leg}_thigh\">\n{urdf_inertial(*b['thigh'], 4)}  </link>\n")
        out.append(f"  <joint name=\"{leg}_KFE\" type=\"revolute\">\n"
                   f"    <parent link=\"{leg}_thigh\"/><child link=\"{leg}_shank\"/>\n"
                   f"    <origin xyz=\"{vec((0, 0, -THIGH))}\" rpy=\"0 0 0\"/>\n"
                   f"    <axis xyz=\"0 1 0\"/>\n    {urdf_limit(KFE_LIMITS)}\n  </joint>\n")
        out.append(f"  <link name=\"{leg}_shank\">\n{urdf_inertial(*b['shank'], 4)}  </link>\n")
        out.append(f"  <joint name=\"{leg}_wheel_mount\" type=\"fixed\">\n"
                   f"    <parent link=\"{leg}_shank\"/><child link=\"{leg}_wheel\"/>\n"
                   f"    <origin xyz=\"{vec((0, 0, -SHANK))}\" rpy=\"0 {n(WHEEL_MOUNT_PITCH)} 0\"/>\n"
                   f"  </joint>\n")
        out.append(f"  <link name=\"{leg}_wheel\">\n{urdf_inertial(*b['wheel'], 4)}"
                   f"    <collision><origin xyz=\"0 0 0\" rpy=\"{n(math.pi / 2)} 0 0\"/>"
                   f"<geometry><cylinder radius=\"{n(WHEEL_RADIUS)}\" length=\"{n(WHEEL_WIDTH)}\"/>"
                   f"</geometry></collision>\n  </link>\n")
        out.append(f"  <joint name=\"{leg}_contact_point\" type=\"fixed\">\n"
                   f"    <parent link=\"{leg}_wheel\"/><child link=\"{leg}_contact\"/>\n"
                   f"    <origin xyz=\"0 0 {n(-WHEEL_RADIUS)}\" rpy=\"0 0 0\"/>\n  </joint>\n"
                   f"  <link name=\"{leg}_contact\"/>\n")
    out.append("</robot>\n")
    return "".join(out)


def mj_inertial(mass, com, inertia):
    d = diagonal_of(inertia)
    return f"<inertial pos=\"{vec(com)}\" mass=\"{n(mass)}\" diaginertia=\"{vec(d)}\"/>"


def nominal_height():
    """Base height above flat ground with the wheels touching, at the nominal posture."""
    _, hfe, kfe = NOMINAL
    return THIGH * math.cos(hfe) + SHANK * math.cos(hfe + kfe) + WHEEL_RADIUS


def make_mjcf():
    height = nominal_height()
    kp, kd = n(SERVO_KP), n(SERVO_KD)
    out = [f"""<!-- wheelquad for MuJoCo 2.2.2 (robots/wheelquad/wheelquad.md). GENERATED by generate.py
     in this folder: edit that, not this. Same bodies, masses, inertias, joint axes and
     limits as wheelquad.urdf (the control model); tests/robot/wheelquad_description_test.cpp
     proves it. Conventions of robots/tachyon3/tachyon3.xml:
       - each wheel is its own body on a hinge about the axle (y) with a velocity servo,
         carrying the URDF wheel link's mass and inertia; it collides as a sphere of the
         wheel radius (a clean point contact on planes and box edges);
       - the leg joints (<leg>_HAA, _HFE, _KFE) are position servos <joint>_servo (kp
         {kp} N m/rad, kd {kd} N m s/rad as joint damping, integrated implicitly),
         force-limited to the joint's effort; drive wheels <leg>_wheel_servo;
       - sensors <joint>_pos / _vel for every joint and wheel, imu_acc, imu_gyro, imu_quat
         at the base centre, <leg>_touch around each wheel.
     Geom groups: 1 = robot (collides with the terrain only: contype 1, conaffinity 0, a low
     friction so that the terrain's applies), 0 = terrain (added by the scenes); sites in 3.
     Simulation settings as Tachyon 3's: 1 ms Euler steps, elliptic cones, contact solref
     0.04, solimp 0.9 0.95 0.001. -->
<mujoco model="wheelquad">
  <compiler angle="radian" autolimits="true" inertiafromgeom="false"/>
  <option timestep="0.001" integrator="Euler" cone="elliptic" gravity="0 0 -9.81"/>
  <size nconmax="200" njmax="600"/>
  <default>
    <geom contype="1" conaffinity="0" condim="3" friction="0.01 0.005 0.0001"
          solref="0.04 1" solimp="0.9 0.95 0.001" group="1" rgba="0.3 0.3 0.35 1"/>
    <default class="leg">
      <joint type="hinge" damping="{kd}"/>
      <position kp="{kp}"/>
    </default>
    <default class="drive">
      <joint type="hinge" axis="0 1 0" damping="0" armature="{n(WHEEL_ARMATURE)}"/>
      <velocity kv="{n(WHEEL_KV)}" forcerange="{n(-WHEEL_EFFORT)} {n(WHEEL_EFFORT)}" ctrlrange="{n(-WHEEL_SPEED)} {n(WHEEL_SPEED)}"/>
    </default>
    <site type="sphere" size="0.01" group="3" rgba="1 0 0 0.3"/>
  </default>
  <worldbody>
    <body name="base" pos="0 0 {n(height)}">
      <freejoint name="base_free"/>
      {mj_inertial(*BASE)}
      <geom name="base_box" type="box" size="{vec(v / 2 for v in BODY_SIZE)}" rgba="0.2 0.45 0.7 1"/>
      <site name="imu" pos="0 0 0"/>
"""]
    wheel_quat = (math.cos(WHEEL_MOUNT_PITCH / 2), 0.0, math.sin(WHEEL_MOUNT_PITCH / 2), 0.0)
    for leg, xs, ys in LEGS:
        b = bodies(ys)
        haa, hfe, kfe = HAA_LIMITS, HFE_LIMITS, KFE_LIMITS
        out.append(f"""      <!-- {leg} -->
      <body name="{leg}_hip" pos="{vec((xs * HAA_X, ys * HAA_Y, 0))}">
        <joint name="{leg}_HAA" class="leg" axis="1 0 0" range="{n(haa[0])} {n(haa[1])}"/>
        {mj_inertial(*b['hip'])}
        <geom name="{leg}_hip_geom" type="cylinder" fromto="0 {n(ys * 0.02)} 0 0 {n(ys * 0.12)} 0" size="{n(HIP_CYL[0])}"/>
        <body name="{leg}_thigh" pos="{vec((0, ys * HIP_OFFSET, 0))}">
          <joint name="{leg}_HFE" class="leg" axis="0 1 0" range="{n(hfe[0])} {n(hfe[1])}"/>
          {mj_inertial(*b['thigh'])}
          <geom name="{leg}_thigh_geom" type="capsule" fromto="0 0 0 0 0 {n(-THIGH)}" size="0.025"/>
          <body name="{leg}_shank" pos="{vec((0, 0, -THIGH))}">
            <joint name="{leg}_KFE" class="leg" axis="0 1 0" range="{n(kfe[0])} {n(kfe[1])}"/>
            {mj_inertial(*b['shank'])}
            <geom name="{leg}_shank_geom" type="capsule" fromto="0 0 0 0 0 {n(-(SHANK - WHEEL_RADIUS - 0.02))}" size="0.018"/>
            <body name="{leg}_wheel" pos="{vec((0, 0, -SHANK))}" quat="{vec(wheel_quat)}">
              <joint name="{leg}_wheel" class="drive"/>
              {mj_inertial(*b['wheel'])}
              <geom name="{leg}_wheel_geom" type="sphere" size="{n(WHEEL_RADIUS)}" rgba="0.1 0.1 0.1 1"/>
              <site name="{leg}_touch" size="{n(WHEEL_RADIUS + 0.005)}"/>
            </body>
          </body>
        </body>
      </body>
""")
    out.append("    </body>\n  </worldbody>\n  <actuator>\n")
    joints = [(f"{leg}_{j}", lim) for leg, _, _ in LEGS
              for j, lim in (("HAA", HAA_LIMITS), ("HFE", HFE_LIMITS), ("KFE", KFE_LIMITS))]
    for name, (lo, hi, _, eff) in joints:
        out.append(f"    <position name=\"{name}_servo\" joint=\"{name}\" class=\"leg\" "
                   f"ctrlrange=\"{n(lo)} {n(hi)}\" forcerange=\"{n(-eff)} {n(eff)}\"/>\n")
    for leg, _, _ in LEGS:
        out.append(f"    <velocity name=\"{leg}_wheel_servo\" joint=\"{leg}_wheel\" class=\"drive\"/>\n")
    out.append("  </actuator>\n  <sensor>\n")
    for name, _ in joints + [(f"{leg}_wheel", None) for leg, _, _ in LEGS]:
        out.append(f"    <jointpos name=\"{name}_pos\" joint=\"{name}\"/>\n"
                   f"    <jointvel name=\"{name}_vel\" joint=\"{name}\"/>\n")
    out.append("    <accelerometer name=\"imu_acc\" site=\"imu\"/>\n"
               "    <gyro name=\"imu_gyro\" site=\"imu\"/>\n"
               "    <framequat name=\"imu_quat\" objtype=\"site\" objname=\"imu\"/>\n")
    for leg, _, _ in LEGS:
        out.append(f"    <touch name=\"{leg}_touch\" site=\"{leg}_touch\"/>\n")
    leg_q = vec(NOMINAL)
    qpos = f"0 0 {n(height)} 1 0 0 0  " + "  ".join(f"{leg_q} 0" for _ in LEGS)
    ctrl = " ".join(leg_q for _ in LEGS) + " 0 0 0 0"
    out.append(f"""  </sensor>
  <!-- Nominal posture: abduction 0, flexion {n(NOMINAL[1])}, knee {n(NOMINAL[2])} rad, wheel centres
       under the hips, base centre {n(height)} m above flat ground (wheels just touching). -->
  <keyframe>
    <key name="nominal" qpos="{qpos}"
         ctrl="{ctrl}"/>
  </keyframe>
</mujoco>
""")
    return "".join(out)


def table():
    rows = [("base (body box)", *BASE)]
    for part, label in (("hip", "hip (abduction to flexion)"), ("thigh", "thigh incl. knee motor"),
                        ("shank", "shank"), ("wheel", "wheel (in-wheel motor, tyre)")):
        rows.append((label + ", each of 4", *bodies(1)[part]))
    total = BASE[0] + 4 * sum(bodies(1)[p][0] for p in ("hip", "thigh", "shank", "wheel"))
    print("| body | mass [kg] | COM in its frame [m] (left legs) | Ixx Iyy Izz about the COM [kg m^2] |")
    print("|---|---|---|---|")
    for label, m, c, i in rows:
        print(f"| {label} | {n(m)} | ({', '.join('%.4g' % v for v in c)}) | "
              f"{' '.join('%.4g' % v for v in diagonal_of(i))} |")
    print(f"| total | {n(total)} | | |")
    print(f"nominal base height {nominal_height():.4f} m")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    parser.add_argument("--table", action="store_true", help="print the mass table")
    args = parser.parse_args()
    if args.table:
        table()
        return 0
    here = os.path.dirname(os.path.abspath(__file__))
    stale = []
    for name, text in (("wheelquad.urdf", make_urdf()), ("wheelquad.xml", make_mjcf())):
        path = os.path.join(here, name)
        if args.check:
            try:
                with open(path, encoding="utf-8") as f:
                    if f.read() != text:
                        stale.append(path)
            except OSError:
                stale.append(path)
        else:
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
    if stale:
        print("out of date with generate.py: " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
