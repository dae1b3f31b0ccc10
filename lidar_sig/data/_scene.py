"""The embedded sample: a small synthetic two-epoch airborne-LiDAR urban scene.

It makes ``epoch1.laz`` and ``epoch2.laz`` (and ``epoch2_aligned.laz``, epoch 2 without its
rotation, for the change map, which compares the same ground cell by cell): a demo and test data
set that fits in a package. Real data sets are large and have licences; this scene is made
here, from fixed seeds, the same on every machine.

The scene is a square urban block in Lambert-93 coordinates (EPSG:2154):

* gently sloped, slightly undulating terrain and two straight roads (ASPRS class 2, ground);
* gable-roofed buildings, some rotated, with sparse wall points (class 6);
* trees with ellipsoidal crowns and a few trunk points (class 5, high vegetation), and small
  bushes (class 3, low vegetation).

Points are simulated as nadir laser pulses, like a simple airborne scanner. Pulses are spread
uniformly in x/y. A pulse gives one return on ground and roofs, and up to four returns in
vegetation, where the last return may reach the ground. The scanner only sees a few points on
vertical walls.

Epoch 2 is the same place, changed:

* about one third of the trees are removed (deforestation);
* a new gable-roof building stands on a lot that was open ground;
* the whole scene is rotated by 20 degrees about the vertical axis through the scene centre;
* it is sampled again at 80 % of the epoch 1 pulse density, with another random seed (new
  pulses, not a subsample of epoch 1).

Everything comes from fixed seeds and fixed header fields (including the creation date), so the
files are the same byte for byte each time (tests/test_data_samples.py checks the repository's
``data_samples/`` against them). It needs only numpy and laspy (with the lazrs backend for LAZ).

Note on size: a 120 m square at 8 pulses/m^2 would give more than 120,000 points, too many for
a small sample. So the scene keeps a realistic airborne density (8 pulses/m^2, like recent
national LiDAR surveys) and is smaller, 64 m x 64 m: about 40,000 points in epoch 1.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass

import numpy as np

# ---------------------------------------------------------------------------
# Scene constants
# ---------------------------------------------------------------------------

SCENE_SIZE = 64.0  # m, side of the square scene (local frame 0..SCENE_SIZE)
# World (Lambert-93) coordinates of the local origin, somewhere in southern
# France, so that coordinates look like real projected data.
ORIGIN_X = 770_470.0
ORIGIN_Y = 6_277_470.0
BASE_ELEVATION = 40.0  # m, terrain height at the local origin

PULSE_DENSITY = 8.0  # pulses per m^2 for epoch 1 (horizontal surfaces)
PULSE_RATE = 50_000.0  # pulses per second, sets the GPS time step
WALL_DENSITY = 0.6  # points per m^2 of wall: nadir scanners see few walls
Z_NOISE = 0.02  # m, ranging noise on hard surfaces

LAYOUT_SEED = 2154  # buildings, trees, bushes, and the epoch 2 changes
EPOCHS = {
    # epoch: (sampling seed, density factor, rotation in degrees, survey date)
    1: (101, 1.0, 0.0, datetime.date(2024, 6, 3)),
    2: (202, 0.8, 20.0, datetime.date(2025, 6, 2)),
}

# ASPRS classification codes
GROUND, LOW_VEGETATION, HIGH_VEGETATION, BUILDING = 2, 3, 5, 6

# Straight roads: (axis the road runs along, centre line position, half width)
ROADS = (("x", 31.0, 3.0), ("y", 43.0, 3.0))

# Coordinate system VLR text: OGC WKT (WKT1) for RGF93 / Lambert-93.
# Written out, as a file of the time would hold it (TOWGS84 included), so that the files
# stay the same byte for byte whatever pyproj would write today.
EPSG_2154_WKT = (
    'PROJCS["RGF93 / Lambert-93",'
    'GEOGCS["RGF93",'
    'DATUM["Reseau_Geodesique_Francais_1993",'
    'SPHEROID["GRS 1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],'
    'TOWGS84[0,0,0,0,0,0,0],AUTHORITY["EPSG","6171"]],'
    'PRIMEM["Greenwich",0,AUTHORITY["EPSG","8901"]],'
    'UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],'
    'AUTHORITY["EPSG","4171"]],'
    'PROJECTION["Lambert_Conformal_Conic_2SP"],'
    'PARAMETER["standard_parallel_1",49],'
    'PARAMETER["standard_parallel_2",44],'
    'PARAMETER["latitude_of_origin",46.5],'
    'PARAMETER["central_meridian",3],'
    'PARAMETER["false_easting",700000],'
    'PARAMETER["false_northing",6600000],'
    'UNIT["metre",1,AUTHORITY["EPSG","9001"]],'
    'AXIS["Easting",EAST],AXIS["Northing",NORTH],'
    'AUTHORITY["EPSG","2154"]]'
)


# ---------------------------------------------------------------------------
# Scene objects
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Building:
    """Rectangular building with a gable roof; the ridge runs along its length."""

    cx: float
    cy: float
    length: float
    width: float
    azimuth_deg: float  # angle of the ridge from the local x axis
    eave: float  # m above ground
    ridge: float  # m above ground
    intensity: float  # mean roof intensity (roof material)

    def to_local(self, x, y):
        """Coordinates along (u) and across (v) the ridge."""
        a = np.radians(self.azimuth_deg)
        dx, dy = np.asarray(x) - self.cx, np.asarray(y) - self.cy
        return dx * np.cos(a) + dy * np.sin(a), -dx * np.sin(a) + dy * np.cos(a)

    def to_world(self, u, v):
        a = np.radians(self.azimuth_deg)
        return (self.cx + u * np.cos(a) - v * np.sin(a),
                self.cy + u * np.sin(a) + v * np.cos(a))

    def distance(self, x, y):
        """Horizontal distance from (x, y) to the footprint (0 inside)."""
        u, v = self.to_local(x, y)
        du = np.maximum(np.abs(u) - self.length / 2, 0.0)
        dv = np.maximum(np.abs(v) - self.width / 2, 0.0)
        return np.hypot(du, dv)

    def roof_height(self, v):
        """Roof height above ground at cross-ridge offset v (two roof planes)."""
        slope_part = 1.0 - np.abs(v) / (self.width / 2)
        return self.eave + (self.ridge - self.eave) * slope_part


@dataclass(frozen=True)
class Tree:
    x: float
    y: float
    radius: float  # horizontal crown radius
    half_height: float  # vertical crown semi-axis
    crown_base: float  # m above ground, top of the bare trunk
    intensity: float


@dataclass(frozen=True)
class Bush:
    x: float
    y: float
    radius: float
    height: float


@dataclass(frozen=True)
class Scene:
    buildings: tuple
    trees: tuple
    bushes: tuple


# Buildings of epoch 1, placed by hand so that they neither overlap nor
# touch the roads. Heights (ridge) go from 6.5 m to 15 m.
BUILDINGS = (
    Building(11.0, 11.0, 14.0, 9.0, 0.0, 6.0, 9.5, 2600.0),
    Building(30.0, 12.0, 11.0, 8.0, 70.0, 7.0, 10.0, 1300.0),
    Building(12.0, 52.0, 16.0, 10.0, 0.0, 9.0, 13.0, 2200.0),
    Building(31.0, 50.0, 10.0, 7.0, -30.0, 4.5, 7.0, 2800.0),
    Building(55.0, 12.0, 12.0, 8.0, 90.0, 10.0, 13.5, 1500.0),
    Building(55.0, 54.0, 12.0, 9.0, 25.0, 12.0, 15.0, 2000.0),
    Building(10.0, 41.0, 8.0, 6.0, 0.0, 4.0, 6.5, 2400.0),
)
# Built for epoch 2 on a lot kept free of trees and bushes in epoch 1.
NEW_BUILDING = Building(14.0, 22.5, 11.0, 7.0, 10.0, 5.0, 8.0, 3000.0)


# ---------------------------------------------------------------------------
# Terrain and roads
# ---------------------------------------------------------------------------


def distance_to_road(x, y):
    """Horizontal distance to the nearest road (0 on the road)."""
    d = np.full(np.shape(x), np.inf)
    for axis, centre, half_width in ROADS:
        across = y if axis == "x" else x
        d = np.minimum(d, np.maximum(np.abs(across - centre) - half_width, 0.0))
    return d


def terrain_z(x, y):
    """Ground height: a gentle slope plus a small undulation.

    The undulation fades out near the roads, so roads are flat strips that
    only follow the overall slope, with no step at their edges.
    """
    plane = BASE_ELEVATION + 0.03 * x + 0.015 * y
    bumps = 0.35 * np.sin(2 * np.pi * x / 41.0) * np.cos(2 * np.pi * y / 57.0)
    t = np.clip(distance_to_road(x, y) / 6.0, 0.0, 1.0)
    fade = t * t * (3 - 2 * t)  # smoothstep: 0 on the road, 1 six metres away
    return plane + bumps * fade


# ---------------------------------------------------------------------------
# Scene layout (the same for both epochs, apart from the epoch 2 changes)
# ---------------------------------------------------------------------------


def is_free(x, y, radius, buildings, reserved):
    """True if a disc of this radius is clear of buildings and the new lot."""
    if any(b.distance(x, y) < radius + 0.5 for b in buildings):
        return False
    return reserved.distance(x, y) >= radius + 1.0


def place_trees(rng, n_trees=28, max_tries=20_000):
    """Random trees, clear of buildings and each other; trunks off the roads."""
    trees = []
    for _ in range(max_tries):
        if len(trees) == n_trees:
            break
        x, y = rng.uniform(1.0, SCENE_SIZE - 1.0, 2)
        radius = rng.uniform(2.0, 4.0)
        if distance_to_road(x, y) < 1.5:
            continue  # street trees may overhang a road, but not stand on it
        if not is_free(x, y, radius, BUILDINGS, NEW_BUILDING):
            continue
        # crowns may touch a little, as in real tree rows
        if any(np.hypot(x - t.x, y - t.y) < 0.9 * (radius + t.radius) for t in trees):
            continue
        trees.append(Tree(
            x=float(x), y=float(y), radius=float(radius),
            half_height=float(radius * rng.uniform(0.9, 1.4)),
            crown_base=float(rng.uniform(2.5, 5.0)),
            intensity=float(rng.uniform(1200.0, 1700.0)),
        ))
    return trees


def place_bushes(rng, trees, n_bushes=12, max_tries=20_000):
    """Small bushes in the open space left between trees and buildings."""
    bushes = []
    for _ in range(max_tries):
        if len(bushes) == n_bushes:
            break
        x, y = rng.uniform(1.0, SCENE_SIZE - 1.0, 2)
        radius = rng.uniform(0.6, 1.2)
        if distance_to_road(x, y) < radius + 0.5:
            continue
        if not is_free(x, y, radius, BUILDINGS, NEW_BUILDING):
            continue
        if any(np.hypot(x - t.x, y - t.y) < t.radius + radius for t in trees):
            continue
        if any(np.hypot(x - b.x, y - b.y) < b.radius + radius + 1.0 for b in bushes):
            continue
        bushes.append(Bush(float(x), float(y), float(radius),
                           float(rng.uniform(0.6, 1.5))))
    return bushes


def build_scenes():
    """Return the epoch 1 and epoch 2 scenes (layouts, not points yet)."""
    rng = np.random.default_rng(LAYOUT_SEED)
    trees = place_trees(rng)
    bushes = place_bushes(rng, trees)
    epoch1 = Scene(BUILDINGS, tuple(trees), tuple(bushes))

    # Deforestation: remove one third of the trees, chosen at random.
    removed = set(rng.choice(len(trees), size=round(len(trees) / 3), replace=False).tolist())
    kept = tuple(t for i, t in enumerate(trees) if i not in removed)
    epoch2 = Scene(BUILDINGS + (NEW_BUILDING,), kept, tuple(bushes))
    return {1: epoch1, 2: epoch2}


# ---------------------------------------------------------------------------
# Point sampling
# ---------------------------------------------------------------------------


class PointBuffer:
    """Collects points from the scene elements, with the x/y of their pulse.

    The pulse x/y gives the GPS time later, so that all returns of one pulse
    share a time stamp.
    """

    FIELDS = ("x", "y", "z", "classification", "return_number",
              "number_of_returns", "intensity", "pulse_x", "pulse_y")

    def __init__(self):
        self.parts = {name: [] for name in self.FIELDS}

    def add(self, x, y, z, classification, return_number, number_of_returns,
            intensity, pulse_x=None, pulse_y=None):
        n = len(x)
        values = dict(
            x=x, y=y, z=z,
            classification=np.broadcast_to(classification, n),
            return_number=np.broadcast_to(return_number, n),
            number_of_returns=np.broadcast_to(number_of_returns, n),
            intensity=intensity,
            pulse_x=x if pulse_x is None else pulse_x,
            pulse_y=y if pulse_y is None else pulse_y,
        )
        for name in self.FIELDS:
            self.parts[name].append(np.asarray(values[name]))

    def arrays(self):
        return {name: np.concatenate(parts) for name, parts in self.parts.items()}


def noisy_intensity(rng, mean, n, rel_sd=0.12):
    return np.clip(rng.normal(mean, rel_sd * np.asarray(mean), n), 1, 65535)


def sample_roofs(rng, buf, scene, px, py, hit):
    """Single returns on the two roof planes of each building."""
    for i, b in enumerate(scene.buildings):
        m = hit == i
        _, v = b.to_local(px[m], py[m])
        z = terrain_z(b.cx, b.cy) + b.roof_height(v) + rng.normal(0, Z_NOISE, m.sum())
        buf.add(px[m], py[m], z, BUILDING, 1, 1,
                noisy_intensity(rng, b.intensity, m.sum()))


def sample_walls(rng, buf, scene, density_factor):
    """Sparse points on the vertical walls; gable walls go up to the roof line."""
    for b in scene.buildings:
        base = terrain_z(b.cx, b.cy)
        half_l, half_w = b.length / 2, b.width / 2
        # (u, v) ranges of the four walls: two eave walls, two gable walls
        walls = [
            ("long", (-half_l, half_l), -half_w), ("long", (-half_l, half_l), half_w),
            ("gable", (-half_w, half_w), -half_l), ("gable", (-half_w, half_w), half_l),
        ]
        for kind, (lo, hi), fixed in walls:
            top = b.eave if kind == "long" else b.ridge
            n = round(WALL_DENSITY * density_factor * (hi - lo) * top)
            along = rng.uniform(lo, hi, n)
            h = rng.uniform(0.0, top, n)
            if kind == "gable":
                keep = h <= b.roof_height(along)  # triangle under the two roof planes
                along, h = along[keep], h[keep]
            across = fixed + rng.normal(0, Z_NOISE, len(along))  # wall roughness
            u, v = (along, across) if kind == "long" else (across, along)
            x, y = b.to_world(u, v)
            buf.add(x, y, base + h, BUILDING, 1, 1,
                    noisy_intensity(rng, 0.6 * b.intensity, len(x)))


def sample_trees(rng, buf, scene, px, py, hit):
    """Up to four returns per pulse through the crown, the last maybe on the ground.

    The first return is close to the crown surface, later ones are spread
    deeper, so the crown is filled with points and densest near its top.
    Pulses near the trunk axis that go through the crown hit the trunk.
    """
    m = hit >= 0
    px, py, idx = px[m], py[m], hit[m]
    n = len(px)
    trees = scene.trees
    tx = np.array([t.x for t in trees])[idx]
    ty = np.array([t.y for t in trees])[idx]
    radius = np.array([t.radius for t in trees])[idx]
    half_h = np.array([t.half_height for t in trees])[idx]
    base = np.array([t.crown_base for t in trees])[idx]
    inten = np.array([t.intensity for t in trees])[idx]

    g = terrain_z(px, py)
    g_trunk = terrain_z(tx, ty)
    dx, dy = px - tx, py - ty
    d = np.hypot(dx, dy)
    centre_z = g_trunk + base + half_h
    chord = half_h * np.sqrt(np.clip(1 - (d / radius) ** 2, 0.0, 1.0))
    z_top, z_bot = centre_z + chord, centre_z - chord

    n_ret = rng.choice([1, 2, 3, 4], size=n, p=[0.25, 0.35, 0.28, 0.12])

    first = np.maximum(z_top - rng.exponential(0.25, n), z_bot)
    buf.add(px, py, first + rng.normal(0, Z_NOISE, n), HIGH_VEGETATION, 1, n_ret,
            noisy_intensity(rng, inten, n, 0.25), px, py)

    prev = first
    for k in (2, 3, 4):
        has = n_ret >= k
        # 45 % of last returns get through the crown, to the trunk or the ground
        through = has & (n_ret == k) & (rng.random(n) < 0.45)
        inside = has & ~through
        z_in = rng.uniform(z_bot, prev)
        # each return gets less of the pulse energy
        buf.add(px[inside], py[inside], z_in[inside], HIGH_VEGETATION, k, n_ret[inside],
                noisy_intensity(rng, inten[inside] * 0.7 ** (k - 1), inside.sum(), 0.25))
        prev = np.where(inside, z_in, prev)

        trunk = through & (d < 0.6)
        ground = through & ~trunk
        # trunk: snap the return to the bark (trunk radius 15 cm)
        scale = 0.15 / np.maximum(d[trunk], 1e-6)
        z_trunk = rng.uniform(g_trunk[trunk] + 0.3, g_trunk[trunk] + base[trunk])
        buf.add(tx[trunk] + dx[trunk] * scale, ty[trunk] + dy[trunk] * scale, z_trunk,
                HIGH_VEGETATION, k, k, noisy_intensity(rng, 900.0, trunk.sum()),
                px[trunk], py[trunk])
        buf.add(px[ground], py[ground], g[ground] + rng.normal(0, Z_NOISE, ground.sum()),
                GROUND, k, k, noisy_intensity(rng, 700.0, ground.sum(), 0.25))


def sample_bushes(rng, buf, scene, px, py, hit):
    """One or two returns: the bush top, then inside the bush or the ground."""
    m = hit >= 0
    px, py, idx = px[m], py[m], hit[m]
    n = len(px)
    bx = np.array([b.x for b in scene.bushes])[idx]
    by = np.array([b.y for b in scene.bushes])[idx]
    radius = np.array([b.radius for b in scene.bushes])[idx]
    height = np.array([b.height for b in scene.bushes])[idx]

    g = terrain_z(px, py)
    d = np.hypot(px - bx, py - by)
    z_top = g + height * np.sqrt(np.clip(1 - (d / radius) ** 2, 0.0, 1.0))
    n_ret = rng.choice([1, 2], size=n, p=[0.5, 0.5])

    first = np.maximum(z_top - rng.exponential(0.1, n), g)
    buf.add(px, py, first + rng.normal(0, Z_NOISE, n), LOW_VEGETATION, 1, n_ret,
            noisy_intensity(rng, 1600.0, n, 0.25))

    two = n_ret == 2
    to_ground = two & (rng.random(n) < 0.6)
    inside = two & ~to_ground
    buf.add(px[inside], py[inside], rng.uniform(g, first)[inside], LOW_VEGETATION, 2, 2,
            noisy_intensity(rng, 900.0, inside.sum(), 0.25))
    buf.add(px[to_ground], py[to_ground],
            g[to_ground] + rng.normal(0, Z_NOISE, to_ground.sum()), GROUND, 2, 2,
            noisy_intensity(rng, 800.0, to_ground.sum(), 0.25))


def sample_ground(rng, buf, px, py):
    """Single returns on open ground and roads; asphalt is darker than grass."""
    n = len(px)
    z = terrain_z(px, py) + rng.normal(0, Z_NOISE, n)
    on_road = distance_to_road(px, py) == 0.0
    intensity = np.where(on_road, 700.0, 1800.0)
    # dashed white centre lines make the roads stand out in intensity
    for axis, centre, _ in ROADS:
        across, along = (py, px) if axis == "x" else (px, py)
        marking = (np.abs(across - centre) < 0.08) & (np.mod(along, 6.0) < 3.0)
        intensity = np.where(marking, 3200.0, intensity)
    buf.add(px, py, z, GROUND, 1, 1, noisy_intensity(rng, intensity, n))


def first_hit(scene, px, py):
    """For each pulse, which object it meets first from above.

    Returns index arrays (-1 = not hit) for buildings, trees and bushes.
    Roofs stop the pulse; where tree crowns overlap, the higher crown wins.
    """
    n = len(px)
    building_hit = np.full(n, -1)
    for i, b in enumerate(scene.buildings):
        building_hit[b.distance(px, py) == 0.0] = i

    tree_hit = np.full(n, -1)
    best_top = np.full(n, -np.inf)
    for i, t in enumerate(scene.trees):
        d2 = ((px - t.x) ** 2 + (py - t.y) ** 2) / t.radius**2
        chord = t.half_height * np.sqrt(np.clip(1 - d2, 0, 1))
        top = terrain_z(t.x, t.y) + t.crown_base + t.half_height + chord
        better = (d2 < 1.0) & (top > best_top) & (building_hit < 0)
        tree_hit[better], best_top[better] = i, top[better]

    bush_hit = np.full(n, -1)
    for i, b in enumerate(scene.bushes):
        inside = (np.hypot(px - b.x, py - b.y) < b.radius) & (building_hit < 0) & (tree_hit < 0)
        bush_hit[inside] = i
    return building_hit, tree_hit, bush_hit


def sample_scene(scene, seed, density_factor):
    """Simulate the pulses of one acquisition over the scene (local frame)."""
    rng = np.random.default_rng(seed)
    n_pulses = round(PULSE_DENSITY * density_factor * SCENE_SIZE**2)
    px, py = rng.uniform(0.0, SCENE_SIZE, (2, n_pulses))

    building_hit, tree_hit, bush_hit = first_hit(scene, px, py)
    open_ground = (building_hit < 0) & (tree_hit < 0) & (bush_hit < 0)

    buf = PointBuffer()
    sample_ground(rng, buf, px[open_ground], py[open_ground])
    sample_roofs(rng, buf, scene, px, py, building_hit)
    sample_walls(rng, buf, scene, density_factor)
    sample_trees(rng, buf, scene, px, py, tree_hit)
    sample_bushes(rng, buf, scene, px, py, bush_hit)
    return buf.arrays()


# ---------------------------------------------------------------------------
# Georeferencing, time stamps and LAZ output
# ---------------------------------------------------------------------------


def rotate_about_centre(x, y, angle_deg):
    """Rotate local coordinates about the vertical axis at the scene centre."""
    a = np.radians(angle_deg)
    c = SCENE_SIZE / 2
    dx, dy = x - c, y - c
    return c + dx * np.cos(a) - dy * np.sin(a), c + dx * np.sin(a) + dy * np.cos(a)


def adjusted_gps_time(date):
    """Adjusted standard GPS time (GPS seconds - 1e9) at 10:00 on this date."""
    gps_epoch = datetime.datetime(1980, 1, 6)
    leap_seconds = 18  # GPS - UTC since 2017
    start = datetime.datetime.combine(date, datetime.time(10, 0))
    return (start - gps_epoch).total_seconds() + leap_seconds - 1e9


def to_las(pts, date, flight_line):
    """Sort the points in acquisition order and fill a LAS 1.4 / PF 6 record."""
    import laspy
    from laspy.vlrs.known import WktCoordinateSystemVlr

    # The aircraft flies north over the middle of the scene, so pulses are
    # fired in order of northing, at a fixed pulse rate. Returns of one pulse
    # share its time; a rank-based time keeps every pulse time distinct.
    # (The rank of each (pulse_y, pulse_x) among the distinct ones, by lexsort: np.unique(axis=0)
    # compares rows as structured records, and numpy turns a Ctrl-C inside that comparison into
    # a TypeError, which would end the command in a traceback instead of its one line.)
    order = np.lexsort((pts["pulse_x"], pts["pulse_y"]))
    y, x = pts["pulse_y"][order], pts["pulse_x"][order]
    new = np.ones(len(order), bool)
    new[1:] = (y[1:] != y[:-1]) | (x[1:] != x[:-1])
    pulse_rank = np.empty(len(order), np.int64)
    pulse_rank[order] = np.cumsum(new) - 1
    gps_time = adjusted_gps_time(date) + pulse_rank / PULSE_RATE
    order = np.lexsort((pts["return_number"], gps_time))

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.01, 0.01, 0.01])
    # offsets: round numbers just below the minimum
    header.offsets = np.array([
        np.floor(pts["x"].min() / 100.0) * 100.0,
        np.floor(pts["y"].min() / 100.0) * 100.0,
        np.floor(pts["z"].min() / 10.0) * 10.0,
    ])
    # fixed header fields keep the output byte-for-byte reproducible
    header.creation_date = date
    header.system_identifier = "lidar_sig synthetic scanner"
    header.generating_software = "lidar_sig make_scene.py"
    header.global_encoding.gps_time_type = True  # adjusted standard GPS time
    header.vlrs.append(WktCoordinateSystemVlr(EPSG_2154_WKT))
    header.global_encoding.wkt = True

    las = laspy.LasData(header)
    las.x = pts["x"][order]
    las.y = pts["y"][order]
    las.z = pts["z"][order]
    las.intensity = np.round(pts["intensity"][order]).astype(np.uint16)
    las.return_number = pts["return_number"][order].astype(np.uint8)
    las.number_of_returns = pts["number_of_returns"][order].astype(np.uint8)
    las.classification = pts["classification"][order].astype(np.uint8)
    las.gps_time = gps_time[order]
    # scan angle (units of 0.006 degree) from a flying height of 800 m
    flight_x = ORIGIN_X + SCENE_SIZE / 2
    angle = np.degrees(np.arctan2(pts["pulse_x"][order] - flight_x, 800.0))
    las.scan_angle = np.round(angle / 0.006).astype(np.int16)
    las.point_source_id = np.full(len(order), flight_line, dtype=np.uint16)
    return las


def make_epoch(scene, epoch, rotate=True):
    seed, density_factor, rotation_deg, date = EPOCHS[epoch]
    if not rotate:
        rotation_deg = 0.0
    pts = sample_scene(scene, seed, density_factor)
    for xk, yk in (("x", "y"), ("pulse_x", "pulse_y")):
        x, y = rotate_about_centre(pts[xk], pts[yk], rotation_deg)
        pts[xk], pts[yk] = x + ORIGIN_X, y + ORIGIN_Y
    return to_las(pts, date, flight_line=epoch)


#: The sample's files: name -> (epoch, rotated as surveyed).
FILES = {"epoch1.laz": (1, True), "epoch2.laz": (2, True), "epoch2_aligned.laz": (2, False)}


def sample_las():
    """The sample's files as ``laspy.LasData``, by name (:data:`FILES`)."""
    scenes = build_scenes()
    return {name: make_epoch(scenes[epoch], epoch, rotate) for name, (epoch, rotate) in FILES.items()}
