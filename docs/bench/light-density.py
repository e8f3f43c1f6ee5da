"""How well can one light point serve every receiver of an object? (issue 16, docs/benchmarks.md 7c)

A sphere light of radius R at distance D from the centre of a unit sphere; receivers P spread
over the unit sphere's lit side. One light point y, drawn from a density p on the light, serves
all of them: receiver P's estimate of its fluence is cos_P(y)^+ / (|y - P|^2 p(y)). For a
discretised light (N equal-area cells) and a set of receivers, the density that minimises the sum
of the receivers' relative variances is p_i ~ sqrt(sum_j g_ij^2 / E_j^2) (g_ij: receiver j's
integrand on cell i, E_j its fluence). This prints the per-sample relative spread that optimum
leaves, by the receivers' angle from the axis, beside the centre's density (0.9 by solid angle
from the object's centre + 0.1 uniform on the visible cap), which spindle used before.

    python3 docs/bench/light-density.py        # needs numpy; about a minute
"""
import numpy as np

R, D = 0.1, 4.0
CELLS = 200_000
RECEIVERS = 300
light_center = np.array([0.0, 0.0, -D])

# Equal-area cells on the light (a Fibonacci lattice).
i = np.arange(CELLS) + 0.5
z = 1 - 2 * i / CELLS
ring = np.sqrt(1 - z * z)
azimuth = np.pi * (1 + 5**0.5) * i
normals = np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], 1)
points = light_center + R * normals
cell_area = 4 * np.pi * R * R / CELLS

# Receivers uniform on the lit hemisphere of the unit sphere (the side facing the light).
rng = np.random.default_rng(0)
receivers = rng.normal(size=(RECEIVERS, 3))
receivers /= np.linalg.norm(receivers, axis=1)[:, None]
receivers[:, 2] = -np.abs(receivers[:, 2])
angle = np.degrees(np.arccos(np.clip(-receivers[:, 2], -1, 1)))


def integrand(p):
    w = p - points
    d = np.linalg.norm(w, axis=1)
    cos = np.maximum((normals * w).sum(1) / d, 0)
    return cos * cell_area / d**2


g = np.array([integrand(p) for p in receivers])
g /= g.sum(1)[:, None]  # each receiver's integrand over its fluence


def spread(density):
    used = density > 0
    variance = (g[:, used] ** 2 / density[used]).sum(1) - 1
    return np.sqrt(np.maximum(variance, 0))


optimum = np.sqrt((g**2).sum(0))
optimum /= optimum.sum()
axis = -light_center / D
cos_centre = normals @ axis
cone = np.maximum(cos_centre, 0)
cone /= cone.sum()
gamma = np.arccos(R / (D + 1)) + np.arcsin(1 / D)
cap = (cos_centre >= np.cos(gamma)).astype(float)
cap /= cap.sum()
centre = 0.9 * cone + 0.1 * cap

print("receivers' angle from the axis | optimal single density | the centre's (0.9 cone + 0.1 cap)")
for lo, hi in [(0, 20), (20, 45), (45, 70), (70, 90)]:
    band = (angle >= lo) & (angle < hi)
    print(f"{lo:>2}-{hi} deg | {spread(optimum)[band].mean():.3f} | {spread(centre)[band].mean():.3f}")
