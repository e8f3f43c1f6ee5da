"""Per-sample spread of a sphere light's weight for one path, inside against on the surface.

A path leaves the light in direction w, at angle delta from the axis a the light point was
drawn for (toward an apex). Its weight, relative to the equivalent point light (pi R^2 L_e):

* inside (render/src/scatter/light_sample.rs): y uniform on the disk across a, then uniform
  along the chord along a; weight chord_y(a) / chord_y(w);
* on the surface, as before: share 0.9 by solid angle from a distant apex along a (cosine-
  weighted on the hemisphere facing a), the rest uniform on the cap of half-angle gamma seen
  from the object (R = 0.1 at distance 4 from a unit object); weight max(0, n.w) / (pi pdf_A).

Both means must come out 1 (unbiased); the spread is std/mean. Unit light radius (the spread
does not depend on it). Run: python3 docs/bench/ball-spread.py
"""
import numpy as np

rng = np.random.default_rng(1)
N = 2_000_000


def chord(p, w):
    b = p @ w
    c = (p * p).sum(1) - 1.0
    return 2.0 * np.sqrt(np.maximum(b * b - c, 0.0))


# Inside: disk across z, then along the chord.
rho = np.sqrt(rng.random(N))
phi = 2 * np.pi * rng.random(N)
half = np.sqrt(1 - rho**2)
p = np.stack([rho * np.cos(phi), rho * np.sin(phi), (2 * rng.random(N) - 1) * half], 1)
chord_a = 2 * half

# Surface: the mixture.
share = 0.9
gamma = np.arccos(0.1 / 5.0) + np.arcsin(1 / 4.0)
one_minus_cos_cap = 1 - np.cos(gamma)
by_cone = rng.random(N) < share
u1, u2 = rng.random(N), rng.random(N)
cos_cone = np.sqrt(1 - u1)  # cosine-weighted about z
cos_cap = 1 - u1 * one_minus_cos_cap  # uniform on the cap
cos_t = np.where(by_cone, cos_cone, cos_cap)
sin_t = np.sqrt(np.maximum(1 - cos_t**2, 0))
ang = 2 * np.pi * u2
n = np.stack([sin_t * np.cos(ang), sin_t * np.sin(ang), cos_t], 1)
pdf = share * np.maximum(cos_t, 0) / np.pi + (1 - share) / (2 * np.pi * one_minus_cos_cap)

print("delta_deg  inside: mean spread   surface: mean spread")
for deg in [0, 2, 5, 10, 15, 20, 30]:
    d = np.radians(deg)
    w = np.array([np.sin(d), 0.0, np.cos(d)])
    inside = chord_a / chord(p, w)
    surface = np.maximum(n @ w, 0) / pdf / np.pi
    print(
        f"{deg:9d}  {inside.mean():12.4f} {inside.std() / inside.mean():7.3f}"
        f"   {surface.mean():13.4f} {surface.std() / surface.mean():7.3f}"
    )
