"""rollstep: full-centroidal NMPC for telescopic-wheeled-legged robots, from Python.

What the package offers (numpy arrays in and out, SI units, world frame unless said):

- the model (Pinocchio style): Model, Data, build_model_from_urdf, load_robot_model,
  forward_kinematics, get_frame_placement, get_frame_jacobian, center_of_mass,
  compute_centroidal_momentum(_derivatives), compute_generalized_gravity(_derivatives), ...
- the robot OCP: CentroidalOcp (build from a robot folder and OcpSettings, set the command
  and terrain, solve or run real-time iterations, read the plan);
- the solver on your own linear-quadratic problem: LqProblem;
- the simulator: Simulation (a scene, the robot and a controller, stepped with the state
  readable between steps, the log as numpy columns with units); run_report, run_trials;
- settings objects whose attributes are the YAML keys: OcpSettings, SolverSettings,
  ControlSettings, SceneConfig.

C++ errors arrive as Python exceptions with the C++ message: ValueError (invalid
arguments), IndexError (unknown frame or joint names), ModelError, YamlError, InputError,
OutputError, SimError (all RuntimeError) and RuntimeError for the rest. Long calls
(solves, simulation steps) release the GIL.
"""
import os
import subprocess

import numpy as np

from . import _paths
from ._rollstep import (  # noqa: F401  (re-exported)
    Data,
    InputError,
    Model,
    ModelError,
    OutputError,
    ReferenceFrame,
    SceneConfig,
    SimError,
    YamlError,
    build_model_from_urdf,
    build_model_from_urdf_string,
    center_of_mass,
    compute_centroidal_map,
    compute_centroidal_momentum,
    compute_centroidal_momentum_derivatives,
    compute_contact_torque,
    compute_contact_torque_derivatives,
    compute_forward_kinematics_derivatives,
    compute_generalized_gravity,
    compute_generalized_gravity_derivatives,
    compute_joint_jacobians,
    compute_static_torque,
    difference,
    forward_kinematics,
    get_frame_jacobian,
    get_frame_linear_velocity_derivatives,
    get_frame_placement,
    get_frame_position_derivative,
    get_frame_velocity,
    integrate,
    jacobian_center_of_mass,
    neutral_configuration,
    update_frame_placement,
    update_frame_placements,
)
from . import _rollstep
from ._settings import ControlSettings, OcpSettings, RunSpec, SolverSettings  # noqa: F401



def robots_dir():
    """Folder of the robot descriptions (robots/ of the source tree, or share/rollstep/robots
    once installed; the environment variable ROLLSTEP_ROBOTS_DIR overrides it)."""
    return os.environ.get("ROLLSTEP_ROBOTS_DIR") or _paths.ROBOTS_DIR


def config_dir():
    """Folder of the configuration files (config/ of the source tree, or share/rollstep/config
    once installed; ROLLSTEP_CONFIG_DIR overrides it)."""
    return os.environ.get("ROLLSTEP_CONFIG_DIR") or _paths.CONFIG_DIR


def default_robot():
    """The default robot folder: <robots_dir>/tachyon3."""
    return os.path.join(robots_dir(), "tachyon3")


def _description_file(robot):
    robot = str(robot if robot is not None else default_robot())
    return os.path.join(robot, "centroidal.yaml") if os.path.isdir(robot) else robot


def load_robot_model(robot=None):
    """The free-flyer Model of a robot folder (the URDF its centroidal.yaml names) or of a
    centroidal.yaml file; default: default_robot()."""
    description = _description_file(robot)
    urdf = None
    with open(description, encoding="utf-8") as f:
        tree = _rollstep._yaml_to_python(f.read())
    if not isinstance(tree, dict) or "urdf" not in tree:
        raise ValueError(f"robot description '{description}': no 'urdf' key")
    urdf = os.path.join(os.path.dirname(description), str(tree["urdf"]))
    return build_model_from_urdf(urdf)


def _scene(scene):
    if scene is None:
        return SceneConfig()
    if isinstance(scene, SceneConfig):
        return scene
    if isinstance(scene, dict):
        from ._settings import _to_block
        return SceneConfig.parse(_to_block(scene) + "\n", "scene")
    scene = str(scene)
    if scene.endswith((".yaml", ".yml")) or os.path.sep in scene:
        return SceneConfig.load(scene)
    return SceneConfig(scene)


def _settings_cpp(settings, cls):
    if settings is None:
        return cls()._cpp
    if isinstance(settings, cls):
        return settings._cpp
    if isinstance(settings, (str, os.PathLike)):
        return cls.load(settings)._cpp
    if isinstance(settings, dict):
        return cls(**settings)._cpp
    raise TypeError(f"settings: expected {cls.__name__}, a YAML file name or a dict")


class CentroidalOcp:
    """The robot's full-centroidal OCP with its solver, built as `rollstep plan` builds it.

    State x (nx = 13 + nj): [base position (3, world, m), base quaternion x y z w (4,
    base->world), joint positions q_J (nj, rad or m), centroidal momentum h (6, world axes:
    linear kg m/s, angular about the com kg m^2/s)]. Input u (nu = nj + 3 nc): [joint
    velocities (nj, rad/s or m/s), contact forces (3 per contact, world frame, N, acting on
    the robot)]. Node k is at time times[k] = t0 + k dt [s].

    Arguments:
      robot     robot folder or its centroidal.yaml (default: default_robot())
      settings  OcpSettings, a YAML file name or a dict of keys (default: the defaults)
      scene     terrain: a scene name ('flat', 'step20', 'stairs2': config/scenes/NAME.yaml),
                a SceneConfig, a scene file or a dict of a scene file's keys
      gait      'standing', 'rolling', 'trot' or 'static_walk'
      command   (vx [m/s], vy [m/s], yaw_rate [rad/s]) base velocity command, base frame
      start     (x [m], y [m], yaw [rad]) planar start pose of the references at t0 = 0

    The solver is cold-started (the standing state along the base reference, stance feet
    sharing the weight). solve() and realtime_iteration() release the GIL.
    """

    def __init__(self, robot=None, settings=None, scene="flat", gait="trot",
                 command=(0.0, 0.0, 0.0), start=(0.0, 0.0, 0.0)):
        vx, vy, wz = (float(c) for c in command)
        x, y, yaw = (float(s) for s in start)
        self._ocp = _rollstep._RobotOcp(_description_file(robot), _settings_cpp(settings, OcpSettings),
                                        _scene(scene), gait, vx, vy, wz, x, y, yaw)

    # --- description -----------------------------------------------------------------------
    @property
    def model(self):
        """The robot's Model (rollstep.Model)."""
        return self._ocp.model

    @property
    def settings(self):
        """A copy of the OCP's settings (OcpSettings; changing it does not change the OCP)."""
        return OcpSettings._wrap(self._ocp.settings)

    @property
    def description_file(self):
        """The robot description file (centroidal.yaml) the OCP was built from."""
        return self._ocp.description_file

    nx = property(lambda self: self._ocp.nx, doc="State size 13 + nj.")
    ndx = property(lambda self: self._ocp.ndx, doc="Tangent size 12 + nj.")
    nu = property(lambda self: self._ocp.nu, doc="Input size nj + 3 nc.")
    nc = property(lambda self: self._ocp.nc, doc="Number of contacts.")
    nj = property(lambda self: self._ocp.nj, doc="Number of joints.")
    horizon = property(lambda self: self._ocp.horizon, doc="Number of nodes N (N + 1 states).")
    dt = property(lambda self: self._ocp.dt, doc="Node step [s].")
    contact_names = property(lambda self: self._ocp.contact_names,
                             doc="Contact frame names, in mode-mask bit order.")
    joint_names = property(lambda self: self._ocp.joint_names,
                           doc="Joint names, in the order of q_J and of the joint velocities.")
    tangent_names = property(lambda self: self._ocp.tangent_names,
                             doc="Names of the tangent coordinates (ndx).")
    input_names = property(lambda self: self._ocp.input_names, doc="Names of the inputs (nu).")

    # --- inputs ------------------------------------------------------------------------------
    def standing_state(self, x=0.0, y=0.0, yaw=0.0):
        """The nominal standing state (nx,) at the planar pose (x [m], y [m], yaw [rad]): base
        at the nominal height above the terrain under the feet, level, nominal joints, zero
        momentum."""
        return self._ocp.standing_state(float(x), float(y), float(yaw))

    def set_command(self, command, t0=0.0, start=(0.0, 0.0, 0.0)):
        """Restarts the references at t0 [s] from the planar pose start (x [m], y [m], yaw [rad])
        with the base velocity command (vx [m/s], vy [m/s], yaw_rate [rad/s]), and fills the
        mode schedule from t0. The solver keeps its last solution as the next guess."""
        vx, vy, wz = (float(c) for c in command)
        x, y, yaw = (float(s) for s in start)
        self._ocp.reset(float(t0), x, y, yaw, vx, vy, wz)

    def set_command_schedule(self, schedule, t0=0.0, start=(0.0, 0.0, 0.0)):
        """Same as set_command with a schedule: rows (time [s] after t0, vx [m/s], vy [m/s],
        yaw_rate [rad/s]), each command holding from its time on."""
        x, y, yaw = (float(s) for s in start)
        self._ocp.reset_schedule(float(t0), x, y, yaw, np.asarray(schedule, dtype=float).reshape(-1, 4))

    def set_terrain(self, scene):
        """Replaces the terrain (a scene name, SceneConfig, scene file or dict) without
        rebuilding: ValueError if the OCP cannot take it (regions with more edges than the
        first terrain's, or regions where the first terrain had none)."""
        self._ocp.set_terrain(_scene(scene))

    def initial_guess(self):
        """The cold-start guess (xs (N+1, nx), us (N, nu))."""
        return self._ocp.initial_guess()

    def set_initial_guess(self, xs, us):
        """Sets the solver's guess: xs (N+1, nx), us (N, nu)."""
        self._ocp.set_initial_guess(np.asarray(xs, dtype=float), np.asarray(us, dtype=float))

    def cold_start(self):
        """Sets the solver's guess to initial_guess()."""
        self._ocp.cold_start()

    # --- solving -----------------------------------------------------------------------------
    def solve(self, x0=None):
        """Solves from the state x0 (nx,; default: the standing state at the start pose) in the
        settings' solver mode (converging by default: iterations until the KKT tolerance),
        from the current guess. Returns the status: 'Converged', 'Acceptable',
        'MaxIterations', 'LineSearchFailed', 'Infeasible', ... (the C++ SolverStatus
        names). Releases the GIL."""
        return self._ocp.solve(None if x0 is None else np.asarray(x0, dtype=float))

    def realtime_iteration(self, t, x):
        """One real-time update at time t [s] from the measured state x (nx,), as the MPC runs
        it: moves the horizon to t (the previous solution shifted by whole nodes), anchors the
        stance feet, then realtime_iterations Newton iterations. Returns the status
        ('IterationDone' normally). Releases the GIL."""
        return self._ocp.realtime_iteration(float(t), np.asarray(x, dtype=float))

    # --- the plan ------------------------------------------------------------------------------
    states = property(lambda self: self._ocp.states, doc="States (N+1, nx) of the last solve.")
    inputs = property(lambda self: self._ocp.inputs, doc="Inputs (N, nu) of the last solve.")
    times = property(lambda self: self._ocp.times, doc="Node times (N+1,) [s].")
    modes = property(lambda self: self._ocp.modes,
                     doc="Contact mode of each node (N+1,): bit i set = contact i in stance.")
    contact_forces = property(lambda self: self._ocp.contact_forces,
                              doc="Contact forces (N, nc, 3) [N], world frame, acting on the robot.")
    foot_positions = property(lambda self: self._ocp.foot_positions,
                              doc="Contact frame origins (N+1, nc, 3) [m], world frame.")
    base_twists = property(lambda self: self._ocp.base_twists,
                           doc="Base twist (N+1, 6) [m/s, rad/s], base LOCAL frame (the last "
                               "node repeats the last input's).")
    joint_torques = property(lambda self: self._ocp.joint_torques,
                             doc="Static joint torques S (g - J^T f) (N, nj) [N m or N].")
    status = property(lambda self: self._ocp.status, doc="Status of the last solve or update.")
    message = property(lambda self: self._ocp.message,
                       doc="Why the last solve did not succeed ('' otherwise).")
    iterations = property(lambda self: self._ocp.iterations, doc="Iterations of the last solve.")
    cost = property(lambda self: self._ocp.cost, doc="Cost of the returned iterate.")
    solve_time = property(lambda self: self._ocp.solve_time,
                          doc="Wall time [s] of the last solve or real-time iteration.")
    stats = property(lambda self: self._ocp.stats, doc=_rollstep._STATS_DOC)

    def feedback_gain(self, k):
        """Feedback gain K (nu, ndx) of node k < N from the last solve: du = K dx, dx the
        state's tangent deviation (base part local), du the input's (equality projection
        included)."""
        return self._ocp.feedback_gain(int(k))

    def constraint_violations(self):
        """The largest violation of each constraint group of the plan: a list of dicts
        (group, value >= 0, node, row)."""
        return self._ocp.constraint_violations()


def _per_node(value, n, shape, name):
    """A value for every node: one array (shared) or a sequence of n arrays."""
    if value is None:
        return [np.zeros(shape)] * n
    if isinstance(value, (list, tuple)) and len(value) > 0 and np.ndim(value[0]) == len(shape):
        if len(value) != n:
            raise ValueError(f"{name} has {len(value)} nodes; expected N = {n}")
        return [np.asarray(v, dtype=float) for v in value]
    a = np.asarray(value, dtype=float)
    if a.ndim == len(shape) + 1:
        if a.shape[0] != n:
            raise ValueError(f"{name} has {a.shape[0]} nodes; expected N = {n}")
        return [a[k] for k in range(n)]
    return [a] * n


class LqProblem:
    """A linear-quadratic optimal control problem, solved by rollstep's interior point
    Riccati solver:

        min  sum_{k<N} 0.5 x'Q_k x + 0.5 u'R_k u + u'S_k x + q_k'x + r_k'u
             + 0.5 x_N'QN x_N + qN'x_N
        s.t. x_{k+1} = A_k x_k + B_k u_k + c_k,   x_0 = x0,
             u_lo_k <= u_k <= u_hi_k (k < N),  x_lo_k <= x_k <= x_hi_k (k >= 1),
             lg_k <= C_k x_k + D_k u_k <= ug_k (k < N),  lgN <= CN x_N <= ugN,
             E_k x_k + F_k u_k = e_k (k < N).

    Per-node data is one array for every node or a sequence (or stacked array) of N of them.
    A and B are required (their shapes give nx, nu; len(A) or A.shape[0] gives N when A is
    given per node, else pass horizon). Every other term defaults to zero / none; infinite
    bounds are dropped. C_k and E_k may have a different number of rows at each node.
    u_bounds = (u_lo, u_hi): arrays (nu,) for every node or (N, nu), row k for node k;
    x_bounds = (x_lo, x_hi): (nx,) for every node or (N, nx), row k - 1 for node k = 1..N.
    Equalities (E, F, e) are eliminated through the input: F_k must have full row rank
    (a state-only equality is an inequality row with lg = ug). settings: SolverSettings
    (default: converging mode). solve() releases the GIL.
    """

    def __init__(self, A, B, c=None, Q=None, R=None, S=None, q=None, r=None, QN=None, qN=None,
                 u_bounds=None, x_bounds=None, C=None, D=None, lg=None, ug=None, CN=None,
                 lgN=None, ugN=None, E=None, F=None, e=None, horizon=None, settings=None):
        A0 = np.asarray(A[0] if isinstance(A, (list, tuple)) else A, dtype=float)
        if isinstance(A, (list, tuple)):
            n = len(A)
        elif A0.ndim == 3:
            n = A0.shape[0]
        elif horizon is not None:
            n = int(horizon)
        else:
            raise ValueError("horizon: needed when A is one matrix for every node")
        As = _per_node(A, n, (1, 1), "A")
        nx = As[0].shape[0]
        Bs = _per_node(B, n, (1, 1), "B")
        nu = Bs[0].shape[1] if Bs[0].ndim == 2 else 0
        Cs = _per_node(C, n, (0, nx), "C") if C is not None else [np.zeros((0, nx))] * n
        m = [ck.shape[0] for ck in Cs]
        Ds = _per_node(D, n, (0, nu), "D") if D is not None else [np.zeros((mk, nu)) for mk in m]
        lgs = _per_node(lg, n, (0,), "lg") if lg is not None else [np.full(mk, -np.inf) for mk in m]
        ugs = _per_node(ug, n, (0,), "ug") if ug is not None else [np.full(mk, np.inf) for mk in m]
        ulo, uhi = u_bounds if u_bounds is not None else (np.full(nu, -np.inf), np.full(nu, np.inf))
        xlo, xhi = x_bounds if x_bounds is not None else (np.full(nx, -np.inf), np.full(nx, np.inf))
        Es = _per_node(E, n, (0, nx), "E") if E is not None else [np.zeros((0, nx))] * n
        me = [ek.shape[0] for ek in Es]
        Fs = _per_node(F, n, (0, nu), "F") if F is not None else [np.zeros((mk, nu)) for mk in me]
        es = _per_node(e, n, (0,), "e") if e is not None else [np.zeros(mk) for mk in me]

        def bounds(lo, hi, size):
            lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
            if lo.ndim == 2 or hi.ndim == 2:  # per node
                rows = max(lo.shape[0] if lo.ndim == 2 else 1, hi.shape[0] if hi.ndim == 2 else 1)
                return (np.broadcast_to(lo, (rows, size)).copy(),
                        np.broadcast_to(hi, (rows, size)).copy())
            return (np.broadcast_to(lo, (size,)).reshape(1, size).copy(),
                    np.broadcast_to(hi, (size,)).reshape(1, size).copy())

        ulo, uhi = bounds(ulo, uhi, nu)
        xlo, xhi = bounds(xlo, xhi, nx)
        CN = np.zeros((0, nx)) if CN is None else np.asarray(CN, dtype=float)
        mN = CN.shape[0]
        self._lq = _rollstep._LqProblem(
            As, Bs, _per_node(c, n, (nx,), "c"), _per_node(Q, n, (nx, nx), "Q"),
            _per_node(R, n, (nu, nu), "R"), _per_node(S, n, (nu, nx), "S"),
            _per_node(q, n, (nx,), "q"), _per_node(r, n, (nu,), "r"),
            np.zeros((nx, nx)) if QN is None else np.asarray(QN, dtype=float),
            np.zeros(nx) if qN is None else np.asarray(qN, dtype=float),
            ulo, uhi, xlo, xhi,
            Cs, Ds, lgs, ugs, CN,
            np.full(mN, -np.inf) if lgN is None else np.asarray(lgN, dtype=float),
            np.full(mN, np.inf) if ugN is None else np.asarray(ugN, dtype=float),
            Es, Fs, es, _settings_cpp(settings, SolverSettings))

    nx = property(lambda self: self._lq.nx, doc="State size.")
    nu = property(lambda self: self._lq.nu, doc="Input size.")
    horizon = property(lambda self: self._lq.horizon, doc="Number of nodes N.")

    def set_initial_guess(self, xs, us):
        """Sets the solver's guess: xs (N+1, nx), us (N, nu) (default: zeros)."""
        self._lq.set_initial_guess(np.asarray(xs, dtype=float), np.asarray(us, dtype=float))

    def solve(self, x0):
        """Solves from x_0 = x0 (nx,). Returns the status ('Converged', 'Infeasible', ...).
        Releases the GIL."""
        return self._lq.solve(np.asarray(x0, dtype=float))

    def feedback_gain(self, k):
        """Feedback gain K (nu, nx) of node k < N from the last solve: du = K dx (for an
        unconstrained problem the LQR gain, u = K x + k)."""
        return self._lq.feedback_gain(int(k))

    states = property(lambda self: self._lq.states, doc="States (N+1, nx) of the last solve.")
    inputs = property(lambda self: self._lq.inputs, doc="Inputs (N, nu) of the last solve.")
    status = property(lambda self: self._lq.status, doc="Status of the last solve.")
    message = property(lambda self: self._lq.message, doc="Why the last solve failed ('' if not).")
    iterations = property(lambda self: self._lq.iterations, doc="Iterations of the last solve.")
    cost = property(lambda self: self._lq.cost, doc="Cost of the returned iterate.")
    kkt_error = property(lambda self: self._lq.kkt_error, doc="Scaled KKT error at the end.")
    solve_time = property(lambda self: self._lq.solve_time, doc="Wall time of the last solve [s].")


class Simulation:
    """The MuJoCo simulation of `rollstep sim`: the run of a RunSpec, built as `rollstep sim`
    builds it (the plant, the controller, terrain from the scene or perception in closed
    loop, ground truth or the state estimator), stepped at the control rate (1 kHz) with
    the state readable between steps. The same spec gives the same log as `rollstep sim
    --spec` (its log.csv, value for value).

    Arguments:
      spec         a RunSpec, a spec file (e.g. a run's run.yaml) or a dict of its keys; the
                   arguments below are then not used (but control and a SceneConfig scene)
      scene        a scene name ('flat', 'step20', 'stairs2', ...), scene file, SceneConfig
                   or dict
      controller   'stand' (hold the nominal posture), 'drive' (roll on the drive wheels at
                   speed [m/s], turning with turn_speed [m/s]), 'nmpc' (the full pipeline:
                   NMPC + CBF-QP + state integrator) or 'cbfqp' (the CBF-QP baseline
                   without MPC)
      gait, command  for nmpc and cbfqp: gait name and (vx [m/s], vy [m/s], yaw_rate [rad/s])
      control      ControlSettings, a YAML file or a dict (nmpc default: ControlSettings(),
                   the library's defaults, as `rollstep sim`, with deterministic MPC timing;
                   cbfqp default: config/baseline.yaml)
      robot        robot name or folder (its centroidal.yaml and MJCF); default: tachyon3
      log_every    control periods between log rows

    The log keeps a row at the start and every log_every periods: log() gives a dict of
    numpy columns, log_units() their units (the columns of `rollstep sim`'s log.csv, at full
    precision). step() and run() release the GIL.
    """

    def __init__(self, scene="flat", controller="stand", gait="standing", command=(0.0, 0.0, 0.0),
                 control=None, robot=None, speed=0.5, turn_speed=0.0, log_every=10, spec=None):
        scene_cpp = None
        if spec is None:
            values = {"controller": controller, "log_every": int(log_every)}
            if isinstance(scene, (str, os.PathLike)):
                scene = str(scene)
                is_path = scene.endswith((".yaml", ".yml")) or os.path.sep in scene
                values["scene"] = os.path.abspath(scene) if is_path else scene
            else:
                scene_cpp = _scene(scene)
            if controller in ("nmpc", "cbfqp"):
                vx, vy, wz = (float(c) for c in command)
                values["gait"] = gait
                values["command"] = [[0.0, vx, vy, wz]]
            if controller == "nmpc":
                values["mpc_timing"] = "deterministic"
            if controller == "drive":
                values["drive_speed"] = float(speed)
                values["drive_turn_speed"] = float(turn_speed)
            if robot is not None:
                robot = str(robot)
                values["robot"] = os.path.abspath(robot) if os.path.isdir(robot) else robot
            if isinstance(control, (str, os.PathLike)):
                values["control_config"] = os.path.abspath(str(control))
                control = None
            spec = RunSpec(**values)
        else:
            if isinstance(scene, (SceneConfig, dict)):
                scene_cpp = _scene(scene)
            if isinstance(spec, (str, os.PathLike)):
                spec = RunSpec.load(spec)
            elif isinstance(spec, dict):
                spec = RunSpec(**spec)
            if not isinstance(spec, RunSpec):
                raise TypeError("spec: expected a RunSpec, a spec file or a dict")
        control_cpp = None if control is None else _settings_cpp(control, ControlSettings)
        self._sim = _rollstep._Simulation(spec._cpp, control_cpp, scene_cpp)
        self._spec = RunSpec._wrap(self._sim.spec)

    @property
    def spec(self):
        """The RunSpec of this run (a copy); control settings given as ControlSettings or a
        dict are its `control` section, a scene given as a SceneConfig or a dict its
        `inline_scene` (`scene` then its name)."""
        return self._spec.copy()

    def save_spec(self, path):
        """Writes the run's spec to `path` (paths absolute, control settings and a scene
        given in code inline): `rollstep sim --spec PATH` runs the same run again."""
        with open(path, "w", encoding="utf-8") as f:
            f.write(self._sim.spec_yaml())

    @property
    def control_period(self):
        """Control period [s] (one step)."""
        return self._sim.control_period

    @property
    def time(self):
        """Simulated time [s]."""
        return self._sim.time

    @property
    def controller(self):
        """The controller's name."""
        return self._sim.controller_name

    def step(self, steps=1):
        """Runs `steps` control periods (controller, then the plant). Releases the GIL."""
        self._sim.step(int(steps))

    def run(self, duration):
        """Runs `duration` seconds (rounded to whole control periods)."""
        duration = float(duration)
        if not np.isfinite(duration) or duration < 0 or duration > 1e6:
            raise ValueError(f"duration = {duration} s: must be finite and in [0, 1e6] s")
        self._sim.step(int(round(duration / self.control_period)))

    def state(self):
        """The ground truth now, a dict: time [s], base_position (3, world, m),
        base_orientation (w, x, y, z; base->world), base_linear_velocity (3, world, m/s),
        base_angular_velocity (3, base frame, rad/s), joint_position (nj: the robot's servoed
        joints in its MJCF order, rad for revolute, m for prismatic), joint_velocity (nj),
        wheel_position (nw driven wheels, rad), wheel_velocity (nw, rad/s), wheel_center
        (legs, 3) world [m], foot_force (legs, 3) world [N], foot_contact (legs, 0/1),
        body_contact (bool), command_joint_position (nj), command_wheel_velocity (nw).
        Tachyon 3: nj 12 (hips rad, telescopic knees m), nw 4, 6 legs."""
        return self._sim.state()

    def log_units(self):
        """Unit of each log column, a dict (name -> unit, e.g. 'base_x' -> 'm')."""
        return dict(_split_unit(c) for c in self._sim.log_columns())

    def log(self, with_units=False):
        """The log so far, a dict of numpy columns: names as log.csv's without the units
        (time, base_x, ..., fz_LF, ...; log_units() gives the units), or with them
        ('time[s]', 'base_x[m]', ...) if with_units. A column without a unit holds words
        (qp_status: the CBF-QP's status, e.g. 'Optimal'), an array of str."""
        columns = self._sim.log_columns()
        names = columns if with_units else [_split_unit(c)[0] for c in columns]
        return dict(zip(names, self._sim.log_values()))


def _split_unit(column):
    if column.endswith("]") and "[" in column:
        name, unit = column[:-1].split("[", 1)
        return name, unit
    return column, ""


def run_command(args, check=True, capture=False):
    """Runs the `rollstep` program with the arguments `args` (a list of strings: e.g.
    ['report', '--out', 'out/report']); returns its subprocess.CompletedProcess. check:
    raise CalledProcessError on a non-zero exit status. The program is the build tree's or
    the installed one (ROLLSTEP_PROGRAM overrides)."""
    program = os.environ.get("ROLLSTEP_PROGRAM") or _paths.PROGRAM
    return subprocess.run([program] + [str(a) for a in args], check=check,
                          capture_output=capture, text=True)


def run_report(*args, **kwargs):
    """`rollstep report ARGS` (the experiments report): run_report('--out', 'out/report')."""
    return run_command(["report"] + list(args), **kwargs)


def run_trials(*args, **kwargs):
    """`rollstep trials ARGS` (repeated randomised runs)."""
    return run_command(["trials"] + list(args), **kwargs)


__all__ = [name for name in dir() if not name.startswith("_") and name not in ("os", "np", "subprocess")]
