#!/usr/bin/python3
"""Generate render/microfacet_tables.c: the GGX albedo tables of the Principled BSDF.

    /usr/bin/python3 render/gen_microfacet_tables.py > render/microfacet_tables.c

Two kinds of table:

1. Cycles 4.x's own tables, regenerated from their definition (Cycles' app/cycles_precompute
   computes them by Monte Carlo over the GGX sampling routine; we integrate the same
   expectations by quadrature). Cycles reads them with lookup_table_read_*() (linear
   interpolation, coordinates clamped to [0, 1]) at the grid points below.
   - ggx_E[32x32]: albedo of the single-scattering GGX BRDF with F = 1, x = roughness
     (alpha = x^2), y = mu = cos(view, N); grid x/31, y/31 clamped to [1e-4, 1].
     E = E_vndf[ G2/G1 * (reflection above the horizon) ] (eval/pdf of VNDF sampling).
   - ggx_Eavg[32]: 2 * integral over mu of mu * E(mu).
   - ggx_gen_schlick_ior_s[16x16x16]: the VNDF-sample mean of the interpolation factor
     s = saturate(inverse_lerp(F0(eta), 1, F_dielectric(cos_HI, eta))) (0 for samples
     whose reflection is below the horizon), x = roughness, y = mu, z in [1e-4, 0.99] with
     eta = ior_from_F0(z^4). Cycles' layering weight of the Principled specular layer.
2. Our own directional-albedo tables for principled_albedo(): 32x32, x = roughness (x/31),
   y = sqrt(mu) (y/31, so that grazing views, where the albedo changes fastest, get more
   points), z as above with 16 entries:
   - alb4_E[32x32]: ggx_E on this grid.
   - alb4_S[32x32x16]: integral of s(cos_HI; eta) * f_ss * cos, 4.x's height-correlated G.
   - alb4_S5[32x32], alb4_S6[32x32]: integral of (1-c)^5 and c(1-c)^6 (c = cos_HI) times
     f_ss * cos (the Schlick and F82 terms of the metallic Fresnel).
   - alb3_E[32x32], alb3_S[32x32x16]: Blender 3.x's GGX (separable Smith G1*G1) with F = 1
     and with F = s (3.x's interpolate_fresnel_color uses the same s).
   - alb3_D0/D1/D2[64] over mu: the 3.x principled diffuse's albedo is
     D0 + r*D1 + r^2*D2 for roughness r (f = (1-FV/2)(1-FL/2) + RR(FL+FV+FL*FV*(RR-1)),
     RR = r*(1+L.V)).
Quadrature: a midpoint grid over the VNDF sampling domain (Heitz 2018, polar disk map, with
the substitution below that smooths the rim of the disk), QUAD samples per side.
"""
import sys

import numpy as np

QUAD = 192


def ior_from_F0(f0):
    s = np.sqrt(np.clip(f0, 0.0, 0.99))
    return (1.0 + s) / (1.0 - s)


def fresnel_dielectric_cos(c, eta):
    c = np.abs(c)
    g = eta * eta - 1.0 + c * c
    pos = g > 0
    gs = np.sqrt(np.where(pos, g, 1.0))
    A = (gs - c) / (gs + c)
    B = (c * (gs + c) - 1.0) / (c * (gs - c) + 1.0)
    return np.where(pos, 0.5 * A * A * (1.0 + B * B), 1.0)


def s_ior(c, eta):
    """Cycles' generalized-Schlick interpolation factor in its 'real Fresnel' mode."""
    f0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    F = fresnel_dielectric_cos(c, eta)
    return np.clip((F - f0) / (1.0 - f0), 0.0, 1.0)


def lam(alpha2, cos):
    cos2 = np.maximum(cos * cos, 1e-300)
    return 0.5 * (np.sqrt(1.0 + alpha2 * np.maximum(1.0 / cos2 - 1.0, 0.0)) - 1.0)


# Midpoint grid over the sampler's unit square. u1 -> 1 is the rim of the sampled disk,
# where integrands behave like sqrt(1 - u1); u1 = 1 - (1 - t)^2 with weight 2 (1 - t)
# makes them smooth in t, so the midpoint rule in t converges fast.
_t = (np.arange(QUAD) + 0.5) / QUAD
_T, U2 = [a.ravel() for a in np.meshgrid(_t, _t, indexing="ij")]
U1 = 1.0 - (1.0 - _T) ** 2
WEIGHT = 2.0 * (1.0 - _T)


def vndf_samples(rough, mu, singular_alpha2):
    """Half vectors of GGX VNDF sampling for view (sin, 0, mu); returns cos_HI, wo_z, G-terms."""
    alpha = rough * rough
    wi = np.array([np.sqrt(max(0.0, 1.0 - mu * mu)), 0.0, mu])
    if alpha * alpha <= singular_alpha2:
        # Singular: the mirror direction, with eval/pdf = F.
        one = np.ones(1)
        return one * mu, one * mu, one * 0.0, one * 0.0, True
    v = np.array([alpha * wi[0], 0.0, wi[2]])
    v /= np.linalg.norm(v)
    T1 = np.array([0.0, 1.0, 0.0])
    T2 = np.cross(v, T1)
    r = np.sqrt(U1)
    phi = 2.0 * np.pi * U2
    tx = r * np.cos(phi)
    ty = r * np.sin(phi)
    ty = (1.0 - 0.5 * (1.0 + v[2])) * np.sqrt(np.maximum(0.0, 1.0 - tx * tx)) + 0.5 * (1.0 + v[2]) * ty
    tz = np.sqrt(np.maximum(0.0, 1.0 - tx * tx - ty * ty))
    Hx = tx * T1[0] + ty * T2[0] + tz * v[0]
    Hy = tx * T1[1] + ty * T2[1] + tz * v[1]
    Hz = tx * T1[2] + ty * T2[2] + tz * v[2]
    Hx, Hy, Hz = alpha * Hx, alpha * Hy, np.maximum(0.0, Hz)
    n = np.sqrt(Hx * Hx + Hy * Hy + Hz * Hz)
    Hx, Hy, Hz = Hx / n, Hy / n, Hz / n
    cos_hi = Hx * wi[0] + Hz * wi[2]
    wo_z = 2.0 * cos_hi * Hz - wi[2]
    a2 = alpha * alpha
    return cos_hi, wo_z, lam(a2, np.full_like(wo_z, mu)), lam(a2, wo_z), False


def ggx_terms(rough, mu, version):
    """Per-sample (cos_HI, weight) with weight = eval/pdf of the F = 1 lobe, 0 when invalid."""
    thresh = 2e-10 if version == 4 else 1e-7
    cos_hi, wo_z, lam_i, lam_o, singular = vndf_samples(rough, mu, thresh)
    if singular:
        return cos_hi, np.ones(1), np.ones(1)
    valid = wo_z > 0.0
    if version == 4:
        w = (1.0 + lam_i) / (1.0 + lam_i + lam_o)
    else:
        w = 1.0 / (1.0 + lam_o)
    w = np.where(valid, w, 0.0) * WEIGHT
    return cos_hi, w, valid * WEIGHT


def grid(n, lo, hi):
    return [min(max(i / (n - 1), lo), hi) for i in range(n)]


def emit(name, values, per_line=8):
    vals = np.asarray(values, dtype=np.float64).ravel()
    out = ["const float %s[%d] = {" % (name, len(vals))]
    for i in range(0, len(vals), per_line):
        out.append("    " + " ".join("%.8ef," % v for v in vals[i:i + per_line]))
    out.append("};")
    return "\n".join(out)


def main():
    zs16 = grid(16, 1e-4, 0.99)
    etas16 = [float(ior_from_F0(z ** 4)) for z in zs16]
    r32 = grid(32, 1e-4, 1.0)
    r16 = grid(16, 1e-4, 1.0)

    ggx_E = np.zeros((32, 32))
    alb4_E = np.zeros((32, 32))
    alb4_S = np.zeros((16, 32, 32))
    alb4_S5 = np.zeros((32, 32))
    alb4_S6 = np.zeros((32, 32))
    alb3_E = np.zeros((32, 32))
    alb3_S = np.zeros((16, 32, 32))
    for y, mu in enumerate(r32):
        for x, rough in enumerate(r32):
            ggx_E[y, x] = np.mean(ggx_terms(rough, mu, 4)[1])
        mu = max(r32[y] ** 2, 1e-4)
        for x, rough in enumerate(r32):
            c, w, _ = ggx_terms(rough, mu, 4)
            alb4_E[y, x] = np.mean(w)
            alb4_S5[y, x] = np.mean(w * np.clip(1.0 - c, 0, 1) ** 5)
            alb4_S6[y, x] = np.mean(w * c * np.clip(1.0 - c, 0, 1) ** 6)
            for z, eta in enumerate(etas16):
                alb4_S[z, y, x] = np.mean(w * s_ior(c, eta))
            c3, w3, _ = ggx_terms(rough, mu, 3)
            alb3_E[y, x] = np.mean(w3)
            for z, eta in enumerate(etas16):
                alb3_S[z, y, x] = np.mean(w3 * s_ior(c3, eta))
        sys.stderr.write("mu row %d/32\n" % (y + 1))

    # Eavg: 2 * integral_0^1 mu E(mu) dmu, by midpoint rule over mu.
    ggx_Eavg = np.zeros(32)
    n_mu = 64
    for x, rough in enumerate(r32):
        acc = 0.0
        for k in range(n_mu):
            mu = (k + 0.5) / n_mu
            _, w, _ = ggx_terms(rough, mu, 4)
            acc += 2.0 * mu * np.mean(w)
        ggx_Eavg[x] = acc / n_mu

    # Cycles' s table: VNDF mean of s over samples, 0 for invalid ones.
    schlick_s = np.zeros((16, 16, 16))
    for y, mu in enumerate(r16):
        for x, rough in enumerate(r16):
            c, w, valid = ggx_terms(rough, mu, 4)
            for z, eta in enumerate(etas16):
                schlick_s[z, y, x] = np.mean(valid * s_ior(c, eta))

    # 3.x principled diffuse albedo terms over mu, by a cosine-weighted grid over wi.
    n_d = 64
    D = np.zeros((3, n_d))
    q = 512
    uu = (np.arange(q) + 0.5) / q
    TT, B = [a.ravel() for a in np.meshgrid(uu, uu, indexing="ij")]
    A = 1.0 - (1.0 - TT) ** 2             # the rim substitution, as for the GGX grid
    WD = 2.0 * (1.0 - TT)
    Lz = np.sqrt(1.0 - A)                 # cosine-weighted: pdf = cos/pi, f*cos/pdf = f*pi
    rr = np.sqrt(A)
    Lx, Ly = rr * np.cos(2 * np.pi * B), rr * np.sin(2 * np.pi * B)
    for k in range(n_d):
        mu = min(max(k / (n_d - 1), 1e-4), 1.0)
        V = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
        FV = (1.0 - mu) ** 5
        FL = np.clip(1.0 - Lz, 0, 1) ** 5
        LV1 = Lx * V[0] + Lz * V[2] + 1.0
        D[0, k] = np.mean(WD * (1 - 0.5 * FV) * (1 - 0.5 * FL))
        D[1, k] = np.mean(WD * LV1 * (FL + FV - FL * FV))
        D[2, k] = np.mean(WD * LV1 * LV1 * FL * FV)

    print("/* Generated by render/gen_microfacet_tables.py (QUAD=%d); do not edit. */" % QUAD)
    print('#include "render/microfacet_tables.h"\n')
    print(emit("microfacet_ggx_E", ggx_E))
    print(emit("microfacet_ggx_Eavg", ggx_Eavg))
    print(emit("microfacet_ggx_gen_schlick_ior_s", schlick_s))
    print(emit("microfacet_alb4_E", alb4_E))
    print(emit("microfacet_alb4_S", alb4_S))
    print(emit("microfacet_alb4_S5", alb4_S5))
    print(emit("microfacet_alb4_S6", alb4_S6))
    print(emit("microfacet_alb3_E", alb3_E))
    print(emit("microfacet_alb3_S", alb3_S))
    print(emit("microfacet_alb3_D", D))


if __name__ == "__main__":
    main()
