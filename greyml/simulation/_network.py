"""Kernels of the lumped-parameter thermal network.

Pure functions, arrays in and arrays out: no validation, no randomness. The
user-facing builders in :mod:`greyml.simulation._simulate` validate their input
and call these.

The network has ``n`` nodes with heat capacities ``C`` (J/K), conductances
``G_ij`` (W/K) between pairs of nodes and convective conductances ``h_i``
(W/K) from each node to the ambient air. With node temperatures ``T`` (°C),
heat inputs ``P`` (W) and ambient temperature ``T_a`` the energy balance is

.. math::

    C \\dot T = -K T + P + h T_a,\\qquad K = L + \\operatorname{diag}(h),

where ``L`` is the weighted graph Laplacian of the conductances. Written as a
linear system ``x' = A x + B u`` with ``u = (P_1, …, P_n, T_a)``, it is
integrated exactly for inputs that are constant over each step: the zero-order
hold discretisation ``x_{k+1} = Φ x_k + Γ u_k`` with ``Φ = e^{A h}`` and
``Γ = ∫_0^h e^{A s} ds B``, both read off one matrix exponential of the
augmented matrix ``[[A, B], [0, 0]]`` (Van Loan's construction).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm, solve

__all__ = [
    "conductance_matrix",
    "network_matrices",
    "add_lag_states",
    "steady_state",
    "zoh_discretize",
    "propagate",
]


def conductance_matrix(n_nodes, links, convection):
    """Conductance matrix ``K = L + diag(h)`` of a thermal network.

    Parameters
    ----------
    n_nodes : int
        Number of nodes.
    links : array-like of shape (n_links, 3)
        Rows ``(i, j, G_ij)``: node indices and the conductance between them
        in W/K.
    convection : array-like of shape (n_nodes,)
        Conductance from each node to the ambient air in W/K.

    Returns
    -------
    K : ndarray of shape (n_nodes, n_nodes)
        Symmetric, positive definite when every connected part of the network
        touches the air.

    Examples
    --------
    >>> conductance_matrix(2, [(0, 1, 2.0)], [0.5, 0.0])
    array([[ 2.5, -2. ],
           [-2. ,  2. ]])
    """
    K = np.zeros((n_nodes, n_nodes))
    for i, j, g in links:
        i, j = int(i), int(j)
        K[i, i] += g
        K[j, j] += g
        K[i, j] -= g
        K[j, i] -= g
    K[np.diag_indices(n_nodes)] += np.asarray(convection, dtype=float)
    return K


def network_matrices(capacity, links, convection):
    """Continuous-time state matrices of the network.

    Parameters
    ----------
    capacity : array-like of shape (n_nodes,)
        Heat capacity of each node in J/K.
    links : array-like of shape (n_links, 3)
        Rows ``(i, j, G_ij)`` as in :func:`conductance_matrix`.
    convection : array-like of shape (n_nodes,)
        Conductance of each node to the ambient air in W/K.

    Returns
    -------
    A : ndarray of shape (n_nodes, n_nodes)
        ``-C⁻¹ K`` in 1/s.
    B : ndarray of shape (n_nodes, n_nodes + 1)
        ``C⁻¹ [I, h]``: the inputs are the heat flow into every node (W)
        followed by the ambient temperature (°C).

    Examples
    --------
    >>> A, B = network_matrices([100.0], [], [2.0])
    >>> A, B
    (array([[-0.02]]), array([[0.01, 0.02]]))
    """
    c = np.asarray(capacity, dtype=float)
    h = np.asarray(convection, dtype=float)
    K = conductance_matrix(c.size, links, h)
    A = -K / c[:, None]
    B = np.column_stack([np.diag(1.0 / c), h / c])
    return A, B


def add_lag_states(A, B, weights, ambient_weights, tau):
    """Append first-order sensor states to a network's state equations.

    A surface sensor ``s`` reading ``r = w·T + w_a T_a`` through a first-order
    delay obeys ``τ ṡ = r − s``. Putting ``s`` into the state keeps the whole
    simulation exact under the zero-order hold.

    Parameters
    ----------
    A : ndarray of shape (n, n)
    B : ndarray of shape (n, n_inputs)
        Network matrices; the last input is the ambient temperature.
    weights : ndarray of shape (m, n)
        Node weights of the ``m`` lagged sensors.
    ambient_weights : ndarray of shape (m,)
        Weight of the ambient temperature in each lagged sensor.
    tau : ndarray of shape (m,)
        Time constants in s, all positive.

    Returns
    -------
    A_aug : ndarray of shape (n + m, n + m)
    B_aug : ndarray of shape (n + m, n_inputs)

    Examples
    --------
    >>> A, B = add_lag_states(np.array([[-1.0]]), np.array([[1.0, 0.0]]),
    ...                       np.array([[1.0]]), np.array([0.0]), np.array([2.0]))
    >>> A
    array([[-1. ,  0. ],
           [ 0.5, -0.5]])
    """
    n = A.shape[0]
    m = len(tau)
    inv_tau = 1.0 / np.asarray(tau, dtype=float)
    A_aug = np.zeros((n + m, n + m))
    A_aug[:n, :n] = A
    A_aug[n:, :n] = weights * inv_tau[:, None]
    A_aug[n:, n:] = -np.diag(inv_tau)
    B_aug = np.zeros((n + m, B.shape[1]))
    B_aug[:n] = B
    B_aug[n:, -1] = ambient_weights * inv_tau
    return A_aug, B_aug


def steady_state(links, convection, power, ambient):
    """Temperatures at which the network is in equilibrium.

    Solves ``K T = P + h T_a``; the heat capacities do not matter.

    Parameters
    ----------
    links : array-like of shape (n_links, 3)
    convection : array-like of shape (n_nodes,)
    power : array-like of shape (n_nodes,)
        Constant heat input to each node in W.
    ambient : float
        Constant ambient temperature in °C.

    Returns
    -------
    T : ndarray of shape (n_nodes,)

    Examples
    --------
    >>> steady_state([(0, 1, 1.0)], [0.0, 1.0], [1.0, 0.0], 20.0)
    array([22., 21.])
    """
    h = np.asarray(convection, dtype=float)
    K = conductance_matrix(h.size, links, h)
    rhs = np.asarray(power, dtype=float) + h * ambient
    return solve(K, rhs, assume_a="pos")


def zoh_discretize(A, B, dt):
    """Exact discretisation of ``x' = A x + B u`` for inputs held over ``dt``.

    Parameters
    ----------
    A : ndarray of shape (n, n)
    B : ndarray of shape (n, p)
    dt : float
        Step length in s.

    Returns
    -------
    Phi : ndarray of shape (n, n)
        ``exp(A dt)``.
    Gamma : ndarray of shape (n, p)
        ``∫_0^dt exp(A s) ds B``.

    Notes
    -----
    One matrix exponential of the ``(n + p) × (n + p)`` block matrix
    ``[[A, B], [0, 0]] dt`` gives both (Van Loan, 1978).

    Examples
    --------
    >>> Phi, Gamma = zoh_discretize(np.array([[-1.0]]), np.array([[1.0]]), np.log(2))
    >>> np.round([Phi[0, 0], Gamma[0, 0]], 12).tolist()
    [0.5, 0.5]
    """
    n, p = B.shape
    M = np.zeros((n + p, n + p))
    M[:n, :n] = A
    M[:n, n:] = B
    E = expm(M * dt)
    return E[:n, :n], E[:n, n:]


def propagate(Phi, Gamma, kinds, x0, U):
    """Run the recursion ``x_{k+1} = Φ[kind_k] x_k + Γ[kind_k] u_k``.

    Parameters
    ----------
    Phi : ndarray of shape (n_kinds, n, n)
        Transition matrices, one per distinct step length.
    Gamma : ndarray of shape (n_kinds, n, p)
        Input matrices, one per distinct step length.
    kinds : ndarray of int of shape (n_steps,)
        Which step length each step has.
    x0 : ndarray of shape (n,)
        State at the start.
    U : ndarray of shape (n_steps, p)
        Input held over each step.

    Returns
    -------
    X : ndarray of shape (n_steps + 1, n)
        The state at the start of every step and after the last one.

    Notes
    -----
    The input contribution ``Γ u_k`` is computed for all steps in one matrix
    product per step length, so that the loop only does one small
    matrix-vector product per step.

    Examples
    --------
    >>> X = propagate(np.array([[[0.5]]]), np.array([[[0.5]]]), np.zeros(3, int),
    ...               np.array([0.0]), np.ones((3, 1)))
    >>> X[:, 0].tolist()
    [0.0, 0.5, 0.75, 0.875]
    """
    n_steps = len(kinds)
    n = x0.shape[0]
    drive = np.empty((n_steps, n))
    for k in range(Phi.shape[0]):
        sel = kinds == k
        if sel.any():
            drive[sel] = U[sel] @ Gamma[k].T
    X = np.empty((n_steps + 1, n))
    X[0] = x0
    x = x0
    if Phi.shape[0] == 1:
        PhiT = Phi[0].T
        for k in range(n_steps):
            x = x @ PhiT + drive[k]
            X[k + 1] = x
    else:
        PhiT = np.transpose(Phi, (0, 2, 1))
        for k in range(n_steps):
            x = x @ PhiT[kinds[k]] + drive[k]
            X[k + 1] = x
    return X
