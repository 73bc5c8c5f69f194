"""Draft gear of a coupling as TrainDy-class longitudinal simulators model it: free slack (a dead
band), then a loading stiffness while the deflection grows and an unloading stiffness while it
shrinks, the loop between them the energy the gear dissipates (Cole et al., "Modelling, simulation
and applications of longitudinal train dynamics", Vehicle System Dynamics 55(10), 2017, §3: the
loading and unloading curves joined by a transition governed by the relative speed; Cantone,
"TrainDy: the new Union Internationale des Chemins de Fer software for freight train
interoperability", Proc. IMechE F 225, 2011).

Event-free and smooth, so the plant's stiff integrator (BDF) steps through slack closing without
event location:

    e(x)   = s(x - g) - s(-x - g),   s(z) = (z + sqrt(z^2 + eps^2)) / 2     engaged deflection [m]
    f(x, xd) = k_m e + h |e| tanh(xd / v_0) + d w(x) xd                      [N], tension positive
    k_m = (k_l + k_u) / 2,  h = (k_l - k_u) / 2,  w = de/dx in [0, 1]

x the coupling's extension beyond its free length [m], xd its rate [m/s], g half the slack. With
|xd| >> v_0 the spring force is k_l e while |e| grows and k_u e while it shrinks. k_m e is elastic
(potential :func:`potential`), h |e| tanh(xd / v_0) xd >= 0 the hysteresis loss, d w xd^2 >= 0 the
damping loss (the paper's linear damper, acting only with the slack taken up). Zero slack and
k_l = k_u give the paper's coupler f = k x + d xd exactly.
"""
import numpy as np


def _soft(z, eps):
    """s(z) = (z + sqrt(z^2 + eps^2)) / 2, a smooth max(z, 0) [m]."""
    return 0.5 * (z + np.sqrt(z * z + eps * eps))


def _soft_integral(z, eps):
    """S(z) = int_0^z s [m^2] (S' = s)."""
    return 0.25 * z * z + 0.25 * (z * np.sqrt(z * z + eps * eps) + eps * eps * np.arcsinh(z / eps))


def engaged(x, gear):
    """e(x) [m]: the deflection beyond the slack, smooth (``gear`` a :class:`~ecostudy.core.types.DraftGear`)."""
    g, eps = 0.5 * gear.slack, gear.smoothing
    if g == 0:
        return np.asarray(x, float)
    return _soft(x - g, eps) - _soft(-x - g, eps)


def engagement(x, gear):
    """w(x) = de/dx in [0, 1]: 0 inside the slack, 1 beyond it."""
    g, eps = 0.5 * gear.slack, gear.smoothing
    if g == 0:
        return np.ones_like(np.asarray(x, float))
    return 0.5 * (2.0 + (x - g) / np.sqrt((x - g) ** 2 + eps * eps) - (x + g) / np.sqrt((x + g) ** 2 + eps * eps))


def potential(x, gear):
    """U(x) [J]: the elastic energy k_m int_0^x e of a coupling at extension ``x``."""
    g, eps = 0.5 * gear.slack, gear.smoothing
    mean = 0.5 * (gear.loading_stiffness + gear.unloading_stiffness)
    if g == 0:
        return 0.5 * mean * np.asarray(x, float) ** 2
    return mean * (_soft_integral(x - g, eps) + _soft_integral(-x - g, eps) - 2.0 * _soft_integral(-g, eps))


def forces(x, rate, gear, damping):
    """(elastic, hysteresis, damping) parts of a coupling's force [N] at extension ``x`` [m] and
    extension rate ``rate`` [m/s]; ``damping`` d [N s/m]."""
    e = engaged(x, gear)
    mean = 0.5 * (gear.loading_stiffness + gear.unloading_stiffness)
    half = 0.5 * (gear.loading_stiffness - gear.unloading_stiffness)
    return (mean * e, half * np.abs(e) * np.tanh(rate / gear.transition_speed),
            damping * engagement(x, gear) * rate)


def extension(force, gear):
    """The static extension [m] at which the elastic part carries ``force`` [N] (slack taken up)."""
    mean = 0.5 * (gear.loading_stiffness + gear.unloading_stiffness)
    force = np.asarray(force, float)
    return np.sign(force) * 0.5 * gear.slack + force / mean
