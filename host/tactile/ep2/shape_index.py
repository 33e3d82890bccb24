"""Koenderink's shape index S, curvedness R and C, and the HK sign labels (§2.4).

With k1 >= k2 and curvature positive where convex toward the finger,
S = (2/pi) atan2(k1 + k2, k1 - k2): sphere +1, cylinder +0.5, symmetric saddle
0, concave cylinder -0.5, pit -1.  atan2 needs no division by k1 - k2 (which is
0 at umbilics).  Thesis eq. 17 writes S = -(2/pi) atan((kmax+kmin)/(kmax-kmin)):
the opposite sign, because its curvatures are negative on convex surfaces, and
its R is garbled; here R = sqrt((k1^2 + k2^2)/2) and C = (2/pi) ln R (eq. 18).
"""

import numpy as np

TWO_OVER_PI = 2.0 / np.pi

# Table 2 (eight primitives).  Keys: (sign K, sign H) with signs in {-1, 0, 1}.
HK_TABLE2 = {
    (-1, -1): "saddle_valley",
    (-1, 0): "minimal_saddle",
    (-1, 1): "saddle_ridge",
    (0, -1): "valley",
    (0, 0): "flat",
    (0, 1): "ridge",
    (1, -1): "pit",
    (1, 1): "peak",
}
# Table 1 (four primitives, no zero band).
HK_TABLE1 = {
    (-1, -1): "saddle_valley",
    (-1, 1): "saddle_ridge",
    (1, -1): "concave",
    (1, 1): "convex",
}


def shape_index(k1, k2):
    """S in [-1, 1] (eq. 17, sign as above).  Undefined (returned 0) at planes."""
    return TWO_OVER_PI * np.arctan2(k1 + k2, k1 - k2)


def curvedness_r(k1, k2):
    """R = sqrt((k1^2 + k2^2) / 2) without overflow (eq. 17)."""
    return np.hypot(k1, k2) * np.sqrt(0.5)


def curvedness_c(r):
    """C = (2/pi) ln R (eq. 18); only call with R > 0."""
    return TWO_OVER_PI * np.log(r)


def hk_sign(K, H, eps_k=0.0, eps_h=0.0):
    """Signs of (K, H) with zero bands |K| <= eps_k, |H| <= eps_h."""
    sk = np.where(K > eps_k, 1, np.where(K < -eps_k, -1, 0))
    sh = np.where(H > eps_h, 1, np.where(H < -eps_h, -1, 0))
    return sk, sh


def hk_labels(K, H, eps_k=0.0, eps_h=0.0, table=2):
    """HK primitive names (table 1 or 2) for arrays of K and H (0-d for one pair).

    With table 2, K > 0 with H = 0 cannot occur (K <= H^2); a sign pattern
    the table lacks (round-off, or table 1 with a zero sign) reads "flat".
    """
    sk, sh = hk_sign(K, H, eps_k, eps_h)
    names = HK_TABLE2 if table == 2 else HK_TABLE1
    out = np.empty(np.shape(sk), dtype=object)
    for idx in np.ndindex(out.shape):
        out[idx] = names.get((int(sk[idx]), int(sh[idx])), "flat")
    return out


# S regions (6.2.4, fig. 50): the S axis cut into Koenderink's named bands.
S_REGIONS = (
    (-1.0, -0.75, "concave_sphere"),
    (-0.75, -0.25, "concave_cylinder"),
    (-0.25, 0.25, "saddle"),
    (0.25, 0.75, "cylinder"),
    (0.75, 1.0, "sphere"),
)
S_EDGES = np.array([-0.75, -0.25, 0.25, 0.75])
S_NAMES = tuple(name for _, _, name in S_REGIONS)


def s_class(s):
    """Index into ``S_NAMES`` of each S value."""
    return np.searchsorted(S_EDGES, s, side="right")


def s_region_map(s):
    """Array of S-region names for a map of S values (fig. 50)."""
    names = np.array(S_NAMES, dtype=object)
    return names[s_class(np.asarray(s))]
