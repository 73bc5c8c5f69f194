"""Zhang & Zhuan's design model: the cascade train linearised (eq. 2) and discretised by zero-order
hold at Ts, and the fence method's reduced train of virtual cars.

Linearisation (Zhang & Zhuan §II-A step 1): the effort is shifted by the speed-independent and
quadratic parts of the resistance at the operating point, u'_i = u_i - m_i (c0_i + c2_i v_i^2) -
f_p,i, so the origin is an equilibrium, and coupler damping is left out:

    m_i dv_i/dt = u'_i - m_i c1_i v_i + k x_i-1 - k x_i        dx_i/dt = v_i - v_i+1

with the state x = [v_1..v_n, x_1..x_n-1] (speeds, coupler extensions beyond the free length).

Fence method (Zhang & Zhuan §III-C): f consecutive cars of one kind form a virtual car, never mixing
locomotives and wagons, so n_f = sum over the consist's runs of ceil(run / f). The paper does not
say how cars merge; ecostudy's choice (docs/heavyhaul.md): a virtual car's mass is the sum of its
cars', its resistance coefficients are their mass-weighted means, the coupler between two virtual
cars is the chain of real couplers between their centres in series (stiffness k / (number of
couplers spanned)), which keeps the train's total compliance, and a virtual car's effort is shared
among its cars in proportion to their mass (every car then accelerates alike inside it).
"""
import math
from typing import NamedTuple, Optional

import numpy as np
from scipy.linalg import expm


class DesignModel(NamedTuple):
    """x(k+1) = A x(k) + B u'(k) at sample time ``ts`` (Zhang & Zhuan eq. 2), and the continuous pair."""

    A: np.ndarray
    B: np.ndarray
    Ac: np.ndarray
    Bc: np.ndarray
    ts: float
    mass: np.ndarray
    stiffness: np.ndarray   # of each coupler of the model [N/m]


def continuous(mass, c1, stiffness):
    """(A_c, B_c) of the linearised cascade: masses [kg], c1 [1/s] and coupler stiffnesses [N/m]."""
    n = len(mass)
    A = np.zeros((2 * n - 1, 2 * n - 1))
    B = np.zeros((2 * n - 1, n))
    for i in range(n):
        A[i, i] = -c1[i]
        B[i, i] = 1.0 / mass[i]
        if i > 0:
            A[i, n + i - 1] = stiffness[i - 1] / mass[i]
        if i < n - 1:
            A[i, n + i] = -stiffness[i] / mass[i]
            A[n + i, i], A[n + i, i + 1] = 1.0, -1.0
    return A, B


def discretise(Ac, Bc, ts):
    """Zero-order hold: expm of [[A_c, B_c], [0, 0]] ts gives (A, B)."""
    n, m = Bc.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:] = Ac, Bc
    e = expm(big * ts)
    return e[:n, :n], e[:n, n:]


def design_model(mass, c1, stiffness, ts):
    Ac, Bc = continuous(mass, c1, stiffness)
    A, B = discretise(Ac, Bc, ts)
    return DesignModel(A, B, Ac, Bc, ts, np.asarray(mass, float), np.asarray(stiffness, float))


class Represented(NamedTuple):
    """What each term of a (virtual) model's objective stands for in the real train: per (virtual)
    car the cars whose speed it carries and the weight of its effort's square (the sum of its cars'
    squared shares), per (virtual) coupler the real couplers it spans. Ones: every car its own."""

    cars: np.ndarray
    effort: np.ndarray
    couplers: np.ndarray

    @classmethod
    def each(cls, n):
        return cls(np.ones(n), np.ones(n), np.ones(n - 1))


class Fence(NamedTuple):
    """Virtual cars of a consist: ``members[j]`` the car indices of virtual car j, its kind and its
    resistance coefficients (c0, c1, c2: the mass-weighted means of its cars')."""

    members: list
    model: DesignModel
    kinds: tuple
    resistance: np.ndarray
    sharing: str = "mass"   # how a virtual car's effort is shared among its cars: "mass" or "equal"
    spanned: Optional[np.ndarray] = None  # real couplers between the centres of neighbouring virtual cars

    @property
    def locomotives(self):
        """Indices of the locomotive virtual cars."""
        return [j for j, kind in enumerate(self.kinds) if kind == "locomotive"]

    def share(self, virtual_efforts, mass):
        """Per-car efforts [N] from the virtual cars' efforts, shared in proportion to mass (every car
        of a virtual car then accelerates alike) or equally (``sharing``)."""
        out = np.zeros(len(mass))
        for cars, u in zip(self.members, virtual_efforts):
            out[cars] = u * self.shares(cars, mass)
        return out

    def shares(self, cars, mass):
        """Each car's share of its virtual car's effort (``sharing``)."""
        return mass[cars] / mass[cars].sum() if self.sharing == "mass" else np.full(len(cars), 1.0 / len(cars))

    def represented(self, mass, weighting="per_car"):
        """The objective's weights of the virtual cars (:class:`Represented`): ``per_car`` makes the
        reduced objective the full train's sum over its cars and couplers, as nearly as the virtual
        cars allow (a virtual car's speed counts for its cars, its effort's square for the sum of its
        cars' squares, a virtual coupler's force for the real couplers it spans); ``virtual`` weighs
        every virtual car and coupler as one (Zhang & Zhuan's eq. 11 read literally: a group of f wagons
        braking is then penalised about f times more per newton than f wagons of the full model)."""
        if weighting == "virtual":
            return Represented.each(len(self.members))
        if weighting != "per_car":
            raise ValueError(f"fence weighting 'per_car' or 'virtual' (got {weighting})")
        return Represented(np.array([len(cars) for cars in self.members], float),
                           np.array([np.sum(self.shares(cars, mass) ** 2) for cars in self.members]),
                           np.asarray(self.spanned, float))

    def effort_scale(self, largest, mass, weighting="per_car"):
        """Each virtual car's effort unit [N] from its cars' ``largest`` efforts [N] (``objective_scale:
        limits``): ``per_car`` the U with (u / U)^2 = sum over its cars of (share u / U_i)^2 / sum of
        share^2 (its cars' own limit when they are alike), ``virtual`` the sum of its cars' limits."""
        largest = np.asarray(largest, float)
        if weighting == "virtual":
            return np.array([largest[cars].sum() for cars in self.members])
        return np.array([np.sqrt(np.sum(self.shares(cars, mass) ** 2) / np.sum((self.shares(cars, mass) / largest[cars]) ** 2))
                         for cars in self.members])

    def reduce(self, values, mass=None):
        """Per-car speeds (mass-weighted means, with ``mass``) or efforts (sums) of each virtual car."""
        if mass is None:
            return np.array([np.sum(values[cars]) for cars in self.members])
        return np.array([np.dot(values[cars], mass[cars]) / mass[cars].sum() for cars in self.members])


def fence(consist, factor, ts, coupling="series", sharing="mass"):
    """The fence method's reduced design model: virtual cars of ``factor`` cars of one kind.

    ``coupling``: "series" (the real couplers between two virtual cars' centres in series, k /
    couplers spanned: keeps the train's compliance and its slow mode) or "single" (one real coupler,
    k: the reduced train is about f times stiffer). ``sharing``: "mass" or "equal" (:meth:`Fence.share`)."""
    if coupling not in ("series", "single") or sharing not in ("mass", "equal"):
        raise ValueError(f"fence: coupling 'series' or 'single', sharing 'mass' or 'equal' (got {coupling}, {sharing})")
    members = groups(consist.kinds, factor)
    mass = np.array([consist.mass[c].sum() for c in members])
    resistance = np.array([consist.mass[c] @ consist.resistance[c] / consist.mass[c].sum() for c in members])
    centre = [0.5 * (c[0] + c[-1]) for c in members]  # in car indices: couplers spanned between centres
    spanned = np.array([max(b - a, 1.0) for a, b in zip(centre, centre[1:])])
    stiffness = consist.stiffness / (spanned if coupling == "series" else np.ones_like(spanned))
    return Fence(members, design_model(mass, resistance[:, 1], stiffness, ts),
                 tuple(consist.kinds[c[0]] for c in members), resistance, sharing, spanned)


def groups(kinds, factor):
    """The car indices of each virtual car: the runs of consecutive cars of one kind (``kinds``, a
    consist's), cut into pieces of at most ``factor`` cars. Read from the kinds alone, so a study
    counts its locomotive groups (:func:`locomotive_groups`) without building the design model."""
    members, start = [], 0
    kinds = list(kinds)
    while start < len(kinds):
        end = start
        while end < len(kinds) and kinds[end] == kinds[start]:
            end += 1
        members += [np.arange(a, min(a + factor, end)) for a in range(start, end, factor)]
        start = end
    return members


def locomotive_groups(kinds, factor):
    """How many locomotive virtual cars the fence method makes of a consist's ``kinds`` at ``factor``
    (:attr:`Fence.locomotives` of :func:`fence`, without its design model)."""
    return sum(kinds[cars[0]] == "locomotive" for cars in groups(kinds, factor))


def virtual_car_count(runs, factor):
    """n_f = sum of ceil(run / f) over the consist's runs of one kind (Zhang & Zhuan §III-C)."""
    return sum(math.ceil(r / factor) for r in runs)


def paper_counts(cars, nc):
    """Zhang & Zhuan's QP size (§III-B): n Nc control variables and (6 n - 2) Nc constraints."""
    return cars * nc, (6 * cars - 2) * nc
