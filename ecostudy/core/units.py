"""Unit conversions at the file boundary. Everything inside ecostudy is SI (m, s, kg, N, W, J).

Files name their units in field names (``speed_kmh``, ``force_kN``, ``mass_t``); loaders multiply
by the factors below, here and nowhere else.
"""

KMH = 1.0 / 3.6          # [m/s] per [km/h]
KN = 1000.0              # [N] per [kN]
KW = 1000.0              # [W] per [kW]
TONNE = 1000.0           # [kg] per [t]
PERMILLE = 1e-3          # [-] per [per mille]
KWH = 3.6e6              # [J] per [kWh]
PERCENT = 0.01           # [-] per [%]


def to_kmh(speed):
    """Speed [m/s] -> [km/h]."""
    return speed / KMH


def to_kwh(energy):
    """Energy [J] -> [kWh]."""
    return energy / KWH
