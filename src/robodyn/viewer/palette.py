"""The replay's colours: the Okabe–Ito palette, safe for the common colour-vision deficiencies.

M. Okabe and K. Ito, "Color Universal Design (CUD): how to make figures and presentations that
are friendly to colorblind people" (2008): eight colours that stay apart for protanopes,
deuteranopes and tritanopes. Every curve, link, run and arrow of a replay takes one of them; only
the chart cursor is magenta (a hue no curve has) and the static base grey.
"""

from __future__ import annotations

OKABE_ITO = {
    "black": 0x000000,
    "orange": 0xE69F00,
    "sky blue": 0x56B4E9,
    "bluish green": 0x009E73,
    "yellow": 0xF0E442,
    "blue": 0x0072B2,
    "vermillion": 0xD55E00,
    "reddish purple": 0xCC79A7,
}
"""The eight colours by their published names (sRGB)."""

BLACK, ORANGE, SKY_BLUE, BLUISH_GREEN = (OKABE_ITO[n] for n in ("black", "orange", "sky blue", "bluish green"))
YELLOW, BLUE, VERMILLION, REDDISH_PURPLE = (OKABE_ITO[n] for n in ("yellow", "blue", "vermillion", "reddish purple"))
