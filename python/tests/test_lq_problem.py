"""The solver on a user's LQ problem: the unconstrained problem against a Riccati recursion
in numpy, the constrained one against its KKT conditions, per-node data, checks."""
import numpy as np
import pytest

import rollstep


def double_integrator(N=20, dt=0.1):
    A = np.array([[1.0, dt], [0.0, 1.0]])
    B = np.array([[0.5 * dt * dt], [dt]])
    return A, B


def riccati(A, B, Q, R, QN, N, x0):
    P = QN
    K = []
    for _ in range(N):
        k = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
        K.append(k)
        P = Q + A.T @ P @ (A - B @ k)
    K.reverse()
    xs, us = [x0], []
    for k in range(N):
        us.append(-K[k] @ xs[-1])
        xs.append(A @ xs[-1] + B @ us[-1])
    return np.array(xs), np.array(us), K


def test_unconstrained_equals_riccati():
    N = 20
    A, B = double_integrator(N)
    Q, R, QN = np.diag([1.0, 0.1]), np.array([[0.01]]), np.diag([10.0, 1.0])
    lq = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N)
    x0 = np.array([1.0, 0.0])
    assert lq.solve(x0) == "Converged"
    xs, us, K = riccati(A, B, Q, R, QN, N, x0)
    np.testing.assert_allclose(lq.states, xs, atol=1e-9)
    np.testing.assert_allclose(lq.inputs, us, atol=1e-9)
    for k in (0, N // 2, N - 1):
        np.testing.assert_allclose(lq.feedback_gain(k), -K[k], atol=1e-8)
    with pytest.raises(IndexError, match="node 20 out of range"):
        lq.feedback_gain(N)


def test_bounds_and_rows_meet_kkt():
    N = 30
    A, B = double_integrator(N)
    Q, R, QN = np.diag([1.0, 0.1]), np.array([[0.01]]), np.diag([10.0, 1.0])
    # |u| <= 2, velocity >= -0.6 as a general row on every node, final position in [-0.05, 0.05].
    C = [np.array([[0.0, 1.0]])] * N
    D = [np.zeros((1, 1))] * N
    lg = [np.array([-0.6])] * N
    ug = [np.array([np.inf])] * N
    lq = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N, u_bounds=([-2.0], [2.0]), C=C, D=D,
                            lg=lg, ug=ug, CN=np.array([[1.0, 0.0]]), lgN=[-0.05], ugN=[0.05])
    # Infeasible from 2.5 m: 30 nodes at 0.6 m/s cover 1.8 m at most.
    assert lq.solve(np.array([2.5, 0.0])) == "Infeasible"
    x0 = np.array([1.0, 0.0])
    lq.set_initial_guess(np.zeros((N + 1, 2)), np.zeros((N, 1)))
    assert lq.solve(x0) == "Converged"
    xs, us = lq.states, lq.inputs
    assert np.all(np.abs(us) <= 2.0 + 1e-7)
    assert np.all(xs[:-1, 1] >= -0.6 - 1e-7)
    assert abs(xs[-1, 0]) <= 0.05 + 1e-7
    # Active: the velocity row binds (an unconstrained solution would go faster).
    free = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N)
    free.solve(x0)
    assert free.states[:, 1].min() < -0.7
    assert xs[:, 1].min() == pytest.approx(-0.6, abs=1e-5)
    # Dynamics hold exactly (linear).
    np.testing.assert_allclose(xs[1:], xs[:-1] @ A.T + us @ B.T, atol=1e-10)
    # Optimality: no feasible perturbation along the free directions lowers the cost much.
    cost = lq.cost
    rng = np.random.default_rng(0)
    for _ in range(50):
        du = rng.normal(size=us.shape) * 1e-3
        u2 = np.clip(us + du, -2, 2)
        x = [x0]
        for k in range(N):
            x.append(A @ x[-1] + B @ u2[k])
        x = np.array(x)
        if np.all(x[:-1, 1] >= -0.6) and abs(x[-1, 0]) <= 0.05:
            c = sum(0.5 * x[k] @ Q @ x[k] + 0.5 * u2[k] @ R @ u2[k] for k in range(N)) + 0.5 * x[-1] @ QN @ x[-1]
            assert c >= cost - 1e-6


def test_time_varying_data_and_checks():
    N = 5
    A, B = double_integrator(N)
    As = np.stack([A * (1 + 0.01 * k) for k in range(N)])
    lq = rollstep.LqProblem(As, B, Q=np.eye(2), R=np.eye(1), QN=np.eye(2), c=[np.array([0.0, 0.1])] * N)
    assert lq.horizon == N
    x0 = np.array([1.0, 0.0])
    assert lq.solve(x0) == "Converged"
    xs, us = lq.states, lq.inputs
    for k in range(N):
        np.testing.assert_allclose(xs[k + 1], As[k] @ xs[k] + B @ us[k] + [0.0, 0.1], atol=1e-10)
    with pytest.raises(ValueError, match=r"B\[0\] has shape \(3, 1\); expected \(2, 1\)"):
        rollstep.LqProblem(A, np.ones((3, 1)), horizon=3)
    with pytest.raises(ValueError, match="x0 has size 3"):
        lq.solve(np.zeros(3))
    with pytest.raises(ValueError, match="above upper"):
        rollstep.LqProblem(A, B, horizon=3, u_bounds=([1.0], [-1.0]))


def test_no_leak_over_many_problems():
    import resource
    A, B = double_integrator()

    def burst():
        for _ in range(100):
            lq = rollstep.LqProblem(A, B, Q=np.eye(2), R=np.eye(1), QN=np.eye(2), horizon=50,
                                    u_bounds=([-1.0], [1.0]))
            lq.solve(np.array([1.0, 0.0]))
            _ = lq.states, lq.inputs

    burst()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for _ in range(3):
        burst()
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # 300 problems of 51 nodes: kept alive they take about 160 MB on this machine.
    assert after - before < 8000  # kB


def condensed_kkt(A, B, Q, R, QN, x0, N, ineq, eq):
    """The exact solution of the QP in the inputs u = (u_0 .. u_{N-1}) with the active set of
    the given solution: min 0.5 u'H u + g'u s.t. G_a u = h_a (active rows of G u <= h), Eu = d.
    ineq(x_of, u_of) and eq(...) return lists of (row over u, rhs) built from the affine maps
    x_k = s0_k + Su_k u and u_k = Iu_k u. Returns (u, multipliers of the active rows, G, h)."""
    nx, nu = A.shape[0], B.shape[1]
    Su = np.zeros(((N + 1) * nx, N * nu))
    s0 = np.zeros((N + 1) * nx)
    s0[:nx] = x0
    for k in range(N):
        cur, nxt = slice(k * nx, (k + 1) * nx), slice((k + 1) * nx, (k + 2) * nx)
        Su[nxt] = A @ Su[cur]
        Su[nxt, k * nu:(k + 1) * nu] += B
        s0[nxt] = A @ s0[cur]
    Qbig = np.zeros(((N + 1) * nx, (N + 1) * nx))
    for k in range(N + 1):
        Qbig[k * nx:(k + 1) * nx, k * nx:(k + 1) * nx] = QN if k == N else Q
    H = Su.T @ Qbig @ Su + np.kron(np.eye(N), R)
    g = Su.T @ Qbig @ s0

    def x_of(k):
        return Su[k * nx:(k + 1) * nx], s0[k * nx:(k + 1) * nx]

    def u_of(k):
        m = np.zeros((nu, N * nu))
        m[:, k * nu:(k + 1) * nu] = np.eye(nu)
        return m

    G, h = zip(*ineq(x_of, u_of)) if ineq else ((), ())
    E, d = zip(*eq(x_of, u_of)) if eq else ((), ())
    return H, g, np.array(G), np.array(h), np.array(E).reshape(-1, N * nu), np.array(d)


def assert_kkt(lq, H, g, G, h, E, d, tol=1e-6):
    """The solver's inputs solve the QP: feasible, and with the active rows as equalities the
    KKT system gives the same u with non-negative multipliers of the active inequalities."""
    u = lq.inputs.reshape(-1)
    assert np.all(G @ u <= h + tol), "an inequality is violated"
    np.testing.assert_allclose(E @ u, d, atol=tol)
    active = np.abs(G @ u - h) < 1e-5
    M = np.vstack([E, G[active]])
    n, m = H.shape[0], M.shape[0]
    K = np.block([[H, M.T], [M, np.zeros((m, m))]])
    sol = np.linalg.lstsq(K, np.concatenate([-g, d, h[active]]), rcond=None)[0]
    np.testing.assert_allclose(sol[:n], u, atol=1e-5)
    assert np.all(sol[n + E.shape[0]:] >= -1e-6), "a multiplier of an active bound is negative"
    return int(active.sum())


def test_per_node_bounds_meet_kkt():
    N = 20
    A, B = double_integrator(N)
    Q, R, QN = np.diag([1.0, 0.1]), np.array([[0.01]]), np.diag([10.0, 1.0])
    # |u_k| <= 2 on the first half, <= 0.3 on the second; velocity >= -0.8, then >= -0.5.
    u_hi = np.array([[2.0] if k < N // 2 else [0.3] for k in range(N)])
    x_lo = np.array([[-np.inf, -0.8] if k < N // 2 else [-np.inf, -0.5] for k in range(N)])
    lq = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N, u_bounds=(-u_hi, u_hi),
                            x_bounds=(x_lo, np.inf))
    x0 = np.array([1.0, 0.0])
    assert lq.solve(x0) == "Converged"

    def ineq(x_of, u_of):
        rows = []
        for k in range(N):
            rows += [(u_of(k)[0], u_hi[k, 0]), (-u_of(k)[0], u_hi[k, 0])]
        for k in range(1, N + 1):
            Sx, s = x_of(k)
            rows.append((-Sx[1], s[1] - x_lo[k - 1, 1]))
        return rows

    H, g, G, h, E, d = condensed_kkt(A, B, Q, R, QN, x0, N, ineq, None)
    assert assert_kkt(lq, H, g, G, h, E, d) >= 2  # bounds of both halves bind
    # Bounds equal on every node give the same solution as the shared form, bit for bit.
    same = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N,
                              u_bounds=(np.full((N, 1), -2.0), np.full((N, 1), 2.0)))
    shared = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N, u_bounds=([-2.0], [2.0]))
    assert same.solve(x0) == shared.solve(x0) == "Converged"
    assert np.array_equal(same.inputs, shared.inputs)
    with pytest.raises(ValueError, match=r"input bounds have shape \(3, 1\); expected"):
        rollstep.LqProblem(A, B, horizon=N, u_bounds=(np.zeros((3, 1)), np.ones((3, 1))))
    with pytest.raises(ValueError, match=r"state bounds\[4\] 1: lower .* above upper"):
        bad = np.full((N, 2), -1.0)
        bad[4, 1] = 5.0
        rollstep.LqProblem(A, B, horizon=N, x_bounds=(bad, np.ones((N, 2))))


def test_equality_rows_meet_kkt():
    N = 12
    A, B = double_integrator(N)
    Q, R, QN = np.diag([1.0, 0.1]), np.array([[0.01]]), np.diag([10.0, 1.0])
    # u_5 = 0.3 and v_8 + u_8 = 0.1 (rows only on those nodes), |u| <= 1.
    E = [np.zeros((0, 2))] * N
    F = [np.zeros((0, 1))] * N
    e = [np.zeros(0)] * N
    E[5], F[5], e[5] = np.zeros((1, 2)), np.ones((1, 1)), np.array([0.3])
    E[8], F[8], e[8] = np.array([[0.0, 1.0]]), np.ones((1, 1)), np.array([0.1])
    lq = rollstep.LqProblem(A, B, Q=Q, R=R, QN=QN, horizon=N, u_bounds=([-1.0], [1.0]), E=E, F=F,
                            e=e)
    x0 = np.array([1.0, 0.0])
    assert lq.solve(x0) == "Converged"
    assert lq.inputs[5, 0] == pytest.approx(0.3, abs=1e-8)
    assert lq.states[8, 1] + lq.inputs[8, 0] == pytest.approx(0.1, abs=1e-8)

    def ineq(x_of, u_of):
        return [r for k in range(N) for r in ((u_of(k)[0], 1.0), (-u_of(k)[0], 1.0))]

    def eq(x_of, u_of):
        Sx, s = x_of(8)
        return [(u_of(5)[0], 0.3), (Sx[1] + u_of(8)[0], 0.1 - s[1])]

    assert_kkt(lq, *condensed_kkt(A, B, Q, R, QN, x0, N, ineq, eq))
    with pytest.raises(ValueError, match=r"F\[2\] has rank 0 below its 1 rows"):
        F2 = list(F)
        E2 = list(E)
        e2 = list(e)
        E2[2], F2[2], e2[2] = np.array([[1.0, 0.0]]), np.zeros((1, 1)), np.array([0.0])
        rollstep.LqProblem(A, B, horizon=N, E=E2, F=F2, e=e2)
