#!/usr/bin/python3
"""Writes the synthetic OpenVDB test files of this folder with OpenVDB's own Python
bindings (Debian: python3-openvdb, python3-numpy), and, for each, the dense float32 array
haze must import from it (x fastest, ground truth computed here with numpy).

  half_ball.vdb     fog volume saved as half floats, ScaleTranslateMap (voxel 0.1,
                    translation (1, 2, -3)), data at negative indices, an active 8^3 tile
  level_set.vdb     a level-set sphere (haze refuses level sets)
  empty.vdb         a float grid with no voxels
  fog_background.vdb  a fog volume whose background is 0.1 (haze refuses it: density
                    everywhere outside its voxels)
  rotated.vdb       a small fog volume under a rotated transform (an AffineMap; refused)
  scale_map.vdb     the same small fog volume under voxels of 0.1 x 0.2 x 0.3 and no
                    translation (OpenVDB stores it as a ScaleMap)
  mirrored.vdb      a fog volume of 0.01 * (1 + x + 10 y + 100 z) over indices 0..3 in
                    each axis under a transform that mirrors x (scale -0.1, 0.2, 0.3,
                    translation (1, 2, 3): what a grid flipped in Houdini is saved as)
  double.vdb        a fog volume of 64-bit values (a DoubleGrid, as Houdini writes at
                    64-bit precision): 0.1 + 0.01 * (x + 10 y + 100 z) over indices
                    0..3 in each axis, and an 8^3 tile of 0.3 at indices 8..15
  double_half.vdb   double.vdb saved as half floats (saveFloatAsHalf), with an inactive
                    voxel of 0.7 at index (5, 5, 5)
  same_names.vdb    two fog grids both named "density" (0.5 and 0.25 over a 2^3 block),
                    which OpenVDB lists as density[0] and density[1]
  root_tile.vdb     a constant 0.25 over the root tile of indices 0..4095 and a voxel
                    of 0.75 at index (-1, -1, -1) (read through a box given by the caller)
  ball_128.vdb      a 128^3-class smooth, noisy ball (benchmark input)

uncompressed.vdb (frame 24 of plume-a without any compression) comes from
make_uncompressed.cpp: the Python bindings cannot choose a file's compression.
"""
import numpy as np

try:
    import pyopenvdb as vdb
except ImportError:  # OpenVDB 11+ names its module openvdb (as Blender's bundled one)
    import openvdb as vdb

rng = np.random.default_rng(7)


def write_truth(name, dense_zyx):
    """dense_zyx[z, y, x] -> x-fastest float32 little-endian."""
    np.ascontiguousarray(dense_zyx, dtype="<f4").tofile(name + ".bin")


# --- half_ball: indices -6..9 (x), -4..11 (y), -8..7 (z) -------------------------------
lo = np.array([-6, -4, -8])
dims = np.array([16, 16, 16])
idx = np.indices(dims[::-1]).astype(np.float64)  # z, y, x
z, y, x = idx[0] + lo[2], idx[1] + lo[1], idx[2] + lo[0]
r2 = (x - 1.5) ** 2 + (y - 3.5) ** 2 + (z + 0.5) ** 2
dense = np.where(r2 < 36, np.exp(-r2 / 12.0) * (0.8 + 0.2 * rng.random(r2.shape)), 0.0)
dense = dense.astype(np.float32)
grid = vdb.FloatGrid()
grid.copyFromArray(np.ascontiguousarray(np.transpose(dense, (2, 1, 0))), ijk=tuple(int(v) for v in lo))
# An active constant tile over the 8^3 leaf-aligned block at index (0, 0, -8) .. (7, 7, -1).
grid.fill((0, 0, -8), (7, 7, -1), 0.625, active=True)
dense[0:8, 4:12, 6:14] = 0.625  # z -8..-1, y 0..7, x 0..7
grid.name = "density"
grid.gridClass = vdb.GridClass.FOG_VOLUME
grid.saveFloatAsHalf = True
grid.transform = vdb.createLinearTransform(
    np.array([[0.1, 0, 0, 0], [0, 0.1, 0, 0], [0, 0, 0.1, 0], [1.0, 2.0, -3.0, 1]])
)
vdb.write("half_ball.vdb", grids=[grid])
# haze reads the file's bounding box of active values: crop the truth to it.
nz = np.argwhere(dense != 0)
(z0, y0, x0), (z1, y1, x1) = nz.min(axis=0), nz.max(axis=0)
write_truth("half_ball_truth", dense[z0 : z1 + 1, y0 : y1 + 1, x0 : x1 + 1].astype(np.float16).astype(np.float32))
with open("half_ball_truth.json", "w") as f:
    f.write(
        '{"dims": [%d, %d, %d], "index_min": [%d, %d, %d], "voxel_size": 0.1, "translation": [1.0, 2.0, -3.0]}\n'
        % (x1 - x0 + 1, y1 - y0 + 1, z1 - z0 + 1, x0 + lo[0], y0 + lo[1], z0 + lo[2])
    )

# --- level_set ------------------------------------------------------------------------
ls = vdb.createLevelSetSphere(radius=4.0, voxelSize=0.5)
ls.name = "density"
vdb.write("level_set.vdb", grids=[ls])

# --- empty ----------------------------------------------------------------------------
e = vdb.FloatGrid()
e.name = "density"
e.gridClass = vdb.GridClass.FOG_VOLUME
vdb.write("empty.vdb", grids=[e])

# --- fog_background, rotated, root_tile ------------------------------------------------
small = np.zeros((4, 4, 4), dtype=np.float32)
small[1:3, 1:3, 1:3] = 0.5
g = vdb.FloatGrid(0.1)
g.copyFromArray(small)
g.name = "density"
g.gridClass = vdb.GridClass.FOG_VOLUME
vdb.write("fog_background.vdb", grids=[g])
g = vdb.FloatGrid()
g.copyFromArray(small)
g.name = "density"
g.gridClass = vdb.GridClass.FOG_VOLUME
c, s_ = np.cos(0.3), np.sin(0.3)
g.transform = vdb.createLinearTransform(
    np.array([[0.1 * c, 0.1 * s_, 0, 0], [-0.1 * s_, 0.1 * c, 0, 0], [0, 0, 0.1, 0], [0, 0, 0, 1]])
)
vdb.write("rotated.vdb", grids=[g])
g = vdb.FloatGrid()
g.copyFromArray(small)
g.name = "density"
g.gridClass = vdb.GridClass.FOG_VOLUME
g.transform = vdb.createLinearTransform(np.diag([0.1, 0.2, 0.3, 1.0]))
vdb.write("scale_map.vdb", grids=[g])
g = vdb.FloatGrid()
xs = np.arange(4, dtype=np.float32)
g.copyFromArray(0.01 * (1 + xs[:, None, None] + 10 * xs[None, :, None] + 100 * xs[None, None, :]))
g.name = "density"
g.gridClass = vdb.GridClass.FOG_VOLUME
m = np.diag([-0.1, 0.2, 0.3, 1.0])
m[3, :3] = [1.0, 2.0, 3.0]
g.transform = vdb.createLinearTransform(m)
vdb.write("mirrored.vdb", grids=[g])
g = vdb.DoubleGrid()
xs = np.arange(4, dtype=np.float64)
g.copyFromArray(0.1 + 0.01 * (xs[:, None, None] + 10 * xs[None, :, None] + 100 * xs[None, None, :]))
g.fill((8, 8, 8), (15, 15, 15), 0.3, active=True)
g.name = "density"
g.gridClass = vdb.GridClass.FOG_VOLUME
g.transform = vdb.createLinearTransform(voxelSize=0.25)
vdb.write("double.vdb", grids=[g])
# The same saved as half floats, with one inactive voxel of 0.7 at (5, 5, 5) (a leaf whose
# inactive values are 0 and 0.7: OpenVDB stores them apart from the active ones).
g.getAccessor().setValueOff((5, 5, 5), 0.7)
g.saveFloatAsHalf = True
vdb.write("double_half.vdb", grids=[g])
same = []
for value in (0.5, 0.25):
    g = vdb.FloatGrid()
    g.copyFromArray(small * (value / 0.5))
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    same.append(g)
vdb.write("same_names.vdb", grids=same)
g = vdb.FloatGrid()
g.fill((0, 0, 0), (4095, 4095, 4095), 0.25, active=True)
g.getAccessor().setValueOn((-1, -1, -1), 0.75)
g.name = "density"
g.gridClass = vdb.GridClass.FOG_VOLUME
vdb.write("root_tile.vdb", grids=[g])

# --- ball_128 -------------------------------------------------------------------------
n = 128
c = (np.indices((n, n, n)).astype(np.float32) + 0.5) / n - 0.5
r2 = (c**2).sum(axis=0)
noise = rng.random((n // 8, n // 8, n // 8)).astype(np.float32)
noise = np.kron(noise, np.ones((8, 8, 8), dtype=np.float32))
ball = np.where(r2 < 0.16, np.exp(-r2 / 0.05) * (0.6 + 0.4 * noise), 0.0).astype(np.float32)
g = vdb.FloatGrid()
g.copyFromArray(np.ascontiguousarray(np.transpose(ball, (2, 1, 0))))
g.name = "density"
g.gridClass = vdb.GridClass.FOG_VOLUME
g.transform = vdb.createLinearTransform(voxelSize=1.0 / n)
vdb.write("ball_128.vdb", grids=[g])
