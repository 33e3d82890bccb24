"""The jet's terms: monomials x^i y^j / (i! j!) by degree and their rows (value, d/dx,
d/dy), shared by the default fit (``local_jet``), its answers and its consistency test;
and the batched matrix-vector products they all use."""

import numpy as np


def exponents(order):
    """(i, j) of the jet's monomials x^i y^j, by degree (the column order)."""
    return [(i, d - i) for d in range(order + 1) for i in range(d, -1, -1)]


def size(order):
    return (order + 1) * (order + 2) // 2


def rows(x, y, order, dx=0, dy=0):
    """Rows of d^(dx+dy)/dx^dx dy^dy of the jet sum c_ij x^i y^j / (i! j!), (..., p): with
    this scaling a derivative only shifts the exponents (zero where they would go negative),
    and the coefficients are the jet's derivatives at the centre."""
    px, py = powers(x, order), powers(y, order)
    zero = np.zeros_like(x)
    out = [px[i - dx] * py[j - dy] if i >= dx and j >= dy else zero for i, j in exponents(order)]
    return np.stack(out, -1)


def powers(x, order):
    """[x^k / k!] for k = 0..order."""
    out = [np.ones_like(x)]
    for k in range(1, order + 1):
        out.append(out[-1] * x / k)
    return out


def design(x, y, order):
    """Rows of the jet's value, d/dx and d/dy: three (..., p) arrays."""
    return rows(x, y, order), rows(x, y, order, 1, 0), rows(x, y, order, 0, 1)


def mv(M, v):
    """Batched matrix times vector: (B, m, p) @ (B, p) -> (B, m)."""
    return (M @ v[..., None])[..., 0]


def vm(v, M):
    """Batched vector times matrix: (B, m) @ (B, m, p) -> (B, p)."""
    return (v[:, None, :] @ M)[:, 0]


def unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def pick(by_order, which):
    """Per patch, the entry of ``by_order`` (order -> (B, ...)) at that patch's order."""
    out = np.array(next(iter(by_order.values())), copy=True)
    for o, v in by_order.items():
        sel = which == o
        if sel.any():
            out[sel] = v[sel]
    return out
