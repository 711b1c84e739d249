"""The built-in kinds' parameter units, and the names that changed (a light module: no imports)."""

UNITS = {
    "m1": "kg", "m2": "kg", "m": "kg", "m_cart": "kg", "l1": "m", "lc1": "m", "lc2": "m", "l": "m",
    "I1": "kg m^2", "I2": "kg m^2", "I": "kg m^2", "J_m": "kg m^2", "J_l": "kg m^2", "n": "1", "g": "m/s^2",
}  # fmt: skip
"""The SI unit of every built-in kind's parameter ("1": a pure number, the gear ratio)."""

RENAMED = {("cart_pole", "M"): "m_cart", ("geared_arm", "M"): "m"}
"""Parameters once named M: M is only ever the mass matrix, so a mass has a name of its own."""

RENAMED_MEANING = {("cart_pole", "M"): "the cart's mass", ("geared_arm", "M"): "the link's mass"}
"""What each earlier name stood for, as a note about a file that still uses it says it."""
