"""ROS 2 bags of planned paths and Nav2 route graphs of missions.

Checked against independent answers: a bag is opened with ``rosbags`` directly (not the
project's reader) and its poses, frame and stamps compared with the plan's JSON; the
stamps against the timing law on an inclined plane (ground length / speed, turn / yaw
rate); ``energy --waypoints BAG`` against the plan's energy; a mission's graph against a
Python port of the Nav2 route server's GeoJSON loader, which also reads the sample graph
of the navigation2 repository (``tests/fixtures/nav2``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.errors import WaypointError, WaypointIOError
from energy_planner.io.ros2 import FRAME_KEY, read_path_bag, write_path_bag
from energy_planner.mission import Sites, mission
from energy_planner.model import EnergyModel
from energy_planner.problem import Problem
from energy_planner.request import Request
from energy_planner.terrain import Terrain

SAMPLE = Path(__file__).parent / "fixtures" / "nav2" / "sample_graph.geojson"


def _json(r) -> dict:
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout[r.stdout.index("{") :])


def _messages(bag: Path) -> dict[str, list]:
    """Every message of a bag by topic, decoded by rosbags' own reader."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out: dict[str, list] = {}
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as r:
        for c, ns, raw in r.messages():
            out.setdefault(c.topic, []).append((c.msgtype, ns, r.deserialize(raw, c.msgtype)))
    return out


def _yaw(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))


def _hill() -> Terrain:
    """A 40 m x 40 m Gaussian hill, 6 m high, 1 m cells, south-west corner (500000, 5000000)."""
    y, x = np.mgrid[0:40, 0:40]
    z = 6.0 * np.exp(-((x - 22.0) ** 2 + (y - 18.0) ** 2) / (2 * 7.0**2))
    return Terrain.from_array(z, resolution=1.0, origin=(500000.0, 5000000.0))


@pytest.fixture(scope="module")
def hill_dem(tmp_path_factory) -> Path:
    from energy_planner.io import write_geotiff

    h = _hill()
    dem = tmp_path_factory.mktemp("dem") / "hill.tif"
    write_geotiff(dem, h.elevation, transform=h.transform, crs=h.crs)
    return dem


def test_plan_bag_holds_the_path_and_energy_reads_it_back(tmp_path, hill_dem):
    bag = tmp_path / "plan_bag"
    args = ["plan", "--dem", str(hill_dem), "--start", "500004.5,5000004.5", "--goal",
            "500030.5,5000030.5", "--planner", "search", "--speed", "0.4", "--bag", str(bag),
            "--json"]  # fmt: skip
    res = _json(CliRunner().invoke(main, args))
    frame = res["bag_frame"]
    assert res["bag"] == str(bag) and frame["frame"] == "map" and frame["crs"] == "EPSG:32631"
    assert frame["origin"] == [500000.0, 5000000.0, 0.0] and "REP 103" in frame["yaw"]
    msgs = _messages(bag)
    assert list(msgs) == ["/energy_planner/plan"]
    ((msgtype, ns, path),) = msgs["/energy_planner/plan"]
    assert msgtype == "nav_msgs/msg/Path" and path.header.frame_id == "map" and ns == 0
    wps = res["waypoints"]
    assert len(path.poses) == len(wps)
    for ps, w in zip(path.poses, wps, strict=True):
        assert ps.header.frame_id == "map"
        assert ps.pose.position.x + 500000 == pytest.approx(w["x"], abs=1e-6)
        assert ps.pose.position.y + 5000000 == pytest.approx(w["y"], abs=1e-6)
        dyaw = math.remainder(_yaw(ps.pose.orientation) - math.radians(w["yaw_deg"]), math.tau)
        assert abs(dyaw) < 1e-9
    last = path.poses[-1].header.stamp
    assert last.sec + last.nanosec * 1e-9 == pytest.approx(res["duration_s"], abs=2e-9)
    from rosbags.rosbag2 import Reader

    with Reader(bag) as r:
        assert json.loads(r.storage.metadata.custom[FRAME_KEY]) == {
            k: v for k, v in frame.items() if k not in ("topics", "storage")
        }
    # the bag priced again: the plan's energy (times from the stamps, poses from the frame)
    back = _json(CliRunner().invoke(
        main, ["energy", "--dem", str(hill_dem), "--waypoints", str(bag), "--json"]))  # fmt: skip
    assert back["energy_j"] == pytest.approx(res["energy_j"], rel=1e-3)
    assert back["energy_j"] == pytest.approx(res["energy_j"], rel=1e-9)  # in fact exact
    assert back["duration_s"] == pytest.approx(res["duration_s"], rel=1e-9)
    # a bag is never overwritten: the command says so and names the option
    again = CliRunner().invoke(main, args)
    assert again.exit_code == 2 and "exists already" in again.output and "--bag" in again.output


def test_stamps_follow_the_timing_law_on_an_inclined_plane(tmp_path):
    # z = 0.3 x: a metre east is sqrt(1.09) m of ground; a turn of 1 rad at 0.25 rad/s
    # lasts 4 s; walking diagonally takes the longer of its length and its turn
    ter = Terrain.from_function(lambda x, y: 0.3 * x, size=(30, 30))
    x0, y0 = ter.grid[:2]
    st = np.array([[x0 + 3, y0 - 5, 0.0], [x0 + 9, y0 - 5, 0.0], [x0 + 9, y0 - 5, 1.0],
                   [x0 + 9, y0 - 8, 0.2]])  # fmt: skip
    req = Request.make(speed=0.5, yaw_rate=0.25)
    from energy_planner.energy.path import vertex_times

    t = vertex_times(ter, st, req)
    walk = 6 * math.sqrt(1.09) / 0.5
    assert t.tolist() == pytest.approx([0.0, walk, walk + 4.0, walk + 4.0 + 6.0], rel=1e-9)
    with pytest.raises(WaypointError, match="give the request"):
        vertex_times(ter, st, Request(), duration_s=float(t[-1]))  # planned at another speed
    write_path_bag(tmp_path / "b", {"/p": (st, t)}, ter, frame="odom", origin=(x0, y0),
                   start_s=1.7e9, storage="sqlite3")  # fmt: skip
    w = read_path_bag(tmp_path / "b")
    np.testing.assert_allclose(w.xy, st[:, :2], atol=1e-9)
    np.testing.assert_allclose(w.yaw_rad, st[:, 2], atol=1e-12)
    np.testing.assert_allclose(w.t, t, atol=2e-9)
    (_, ns, msg), = _messages(tmp_path / "b")["/p"]  # fmt: skip
    assert msg.header.frame_id == "odom" and ns == 1_700_000_000 * 10**9


def test_path_bag_errors_name_what_is_wrong(tmp_path):
    ter = Terrain.from_function(lambda x, y: 0 * x, size=(10, 10))
    st = np.array([[1.0, 1.0, 0.0], [3.0, 1.0, 0.0]])
    with pytest.raises(WaypointError, match="times must be 2 finite"):
        write_path_bag(tmp_path / "a", {"/p": (st, [0.0])}, ter)
    with pytest.raises(WaypointError, match="not a ROS topic"):
        write_path_bag(tmp_path / "a", {"p": (st, [0.0, 1.0])}, ter)
    with pytest.raises(WaypointError, match="frame"):
        write_path_bag(tmp_path / "a", {"/p": (st, [0.0, 1.0])}, ter, frame=" ")
    assert not (tmp_path / "a").exists() and list(tmp_path.iterdir()) == []
    write_path_bag(tmp_path / "two", {"/a": (st, [0.0, 1.0]), "/b": (st, [0.0, 2.0])}, ter)
    with pytest.raises(WaypointError, match=r"2 path topics \(/a, /b\)"):
        read_path_bag(tmp_path / "two")
    assert read_path_bag(tmp_path / "two", "/b").t.tolist() == [0.0, 2.0]
    with pytest.raises(WaypointError, match="no topic '/c'"):
        read_path_bag(tmp_path / "two", "/c")
    with pytest.raises(WaypointIOError, match="does not exist"):
        read_path_bag(tmp_path / "none")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two"]  # no temporary left


def test_odometry_topic_of_a_log_bag_reads_as_a_path(tmp_path):
    from energy_planner.measurements.rosbag import write_rosbag

    n = 5
    t = np.arange(n) * 0.5
    df = {"run": "r", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0, "vx": 0.3,
          "vy": 0.0, "wz": 0.0, "voltage": 48.0, "current": 5.0, "x": 10 + 0.15 * np.arange(n),
          "y": 20.0, "yaw": 0.1 * np.arange(n)}  # fmt: skip
    import pandas as pd

    (bag,) = write_rosbag(pd.DataFrame(df), tmp_path / "log")
    w = read_path_bag(bag)  # no Path topic: the only Odometry topic, no frame metadata
    assert w.properties["topic"] == "/odom" and w.declared_crs is None
    np.testing.assert_allclose(w.xy[:, 0], df["x"])
    np.testing.assert_allclose(w.yaw_rad, df["yaw"], atol=1e-12)
    np.testing.assert_allclose(w.t, t, atol=1e-9)
    assert "taken in the DEM's CRS" in w.crs_note


# ----------------------------------------------------------------------------- Nav2
_TRIGGERS = ("NODE", "ON_ENTER", "ON_EXIT")


def _uint(v, what):
    assert isinstance(v, int) and not isinstance(v, bool) and v >= 0, f"{what}: {v!r}"
    return v


def _metadata(props, key="metadata"):
    """convertMetaDataFromJson: objects recurse; numbers, booleans, strings, their arrays."""
    out = {}
    for k, v in props.get(key, {}).items():
        if isinstance(v, dict):
            out[k] = _metadata(props[key], k)
            continue
        items = v if isinstance(v, list) else [v]
        for x in items:  # null or a nested array: "Failed to convert"
            assert isinstance(x, bool | int | float | str), f"metadata {k}: {x!r}"
        out[k] = v
    return out


def _operations(props):
    """convertOperationsFromJson: each operation has a type and a known trigger."""
    ops = props.get("operations", {})
    for op in ops.values() if isinstance(ops, dict) else ops:
        assert isinstance(op["type"], str) and op["trigger"] in _TRIGGERS
        _metadata(op)


def nav2_load(doc):
    """GeoJsonGraphFileLoader::loadGraphFromFile in Python (stricter where C++ casts).

    Returns ``{node id: (x, y, frame)}`` and ``[(edge id, start, end, cost, metadata)]``.
    """
    nodes, edges = [], []
    for f in doc["features"]:  # getGraphElements
        kind = f["geometry"]["type"]
        if kind == "Point":
            nodes.append(f)
        elif kind in ("MultiLineString", "LineString"):
            edges.append(f)
    assert nodes and edges, "the graph is malformed: no nodes or no edges"
    graph = {}
    for n in nodes:  # addNodesToGraph
        p = n["properties"]
        nid = _uint(p["id"], "node id")
        x, y = n["geometry"]["coordinates"][:2]
        assert all(isinstance(v, int | float) and not isinstance(v, bool) for v in (x, y))
        frame = p.get("frame", "")
        assert isinstance(frame, str)
        _operations(p)
        _metadata(p)
        graph[nid] = (float(x), float(y), frame)
    out = []
    for e in edges:  # addEdgesToGraph
        p = e["properties"]
        eid, a, b = (_uint(p[k], k) for k in ("id", "startid", "endid"))
        assert a in graph, f"Start id {a} does not exist for edge id {eid}"
        assert b in graph, f"End id of {b} does not exist for edge id {eid}"
        cost = p.get("cost", 0.0)  # convertEdgeCostFromJson
        assert isinstance(cost, int | float) and not isinstance(cost, bool)
        assert isinstance(p.get("overridable", True), bool)
        _operations(p)
        out.append((eid, a, b, float(cost), _metadata(p)))
    ids = list(graph) + [e[0] for e in out]
    assert len(ids) == len(set(ids)), "ids must be unique across nodes and edges"
    return graph, out


def test_the_loader_port_reads_navigation2s_sample_graph():
    graph, edges = nav2_load(json.loads(SAMPLE.read_text()))
    assert len(graph) == 9 and len(edges) == 24 and graph[4] == (1.0, 1.0, "map")
    assert edges[0][:4] == (9, 0, 1, 10.0) and edges[0][4]["speed_limit"] == 0.85
    bad = json.loads(SAMPLE.read_text())
    bad["features"][-1]["properties"]["endid"] = 99
    with pytest.raises(AssertionError, match="End id of 99"):
        nav2_load(bad)


@pytest.fixture(scope="module")
def hill_mission():
    """Three sites on the hill (one on its top), visited and back."""
    hill = _hill()
    prob = Problem(hill, EnergyModel.default(), Request())
    xy = np.array([(4.5, 35.5), (22.5, 21.5), (35.5, 6.5)]) + (500000.0, 5000000.0)
    sites = Sites(xy, ["a", "top", "c"])
    return prob, mission(prob, sites.on_cells(hill), return_to_start=True)


def test_mission_graph_passes_the_route_servers_loader(tmp_path, hill_mission):
    prob, res = hill_mission
    info = res.write_nav2_graph(tmp_path / "g.geojson", prob, battery_wh=30.0, reserve_wh=2.0)
    doc = json.loads((tmp_path / "g.geojson").read_text())
    graph, edges = nav2_load(doc)
    sample = json.loads(SAMPLE.read_text())
    for ours, theirs in ((doc["features"][0], sample["features"][1]),
                         (doc["features"][-1], sample["features"][-1])):  # fmt: skip
        assert ours["type"] == theirs["type"]
        assert ours["geometry"]["type"] == theirs["geometry"]["type"]
        assert set(theirs["properties"]) <= set(ours["properties"])
        for k, v in theirs["properties"].items():
            assert type(ours["properties"][k]) is type(v), k
    assert info["nodes"] == 3 and info["edges"] == 6 == len(edges)
    origin = np.array(doc["energy_planner_frame"]["origin"][:2])
    for i, (x, y, frame) in graph.items():
        assert frame == "map" and np.allclose(np.array([x, y]) + origin, res.sites.xy[i])
    cost = {(a, b): c for _, a, b, c, _ in edges}
    assert set(cost) == {(a, b) for a in range(3) for b in range(3) if a != b}
    for a, b in cost:  # both directions, each its own energy: uphill is not downhill
        assert cost[a, b] != cost[b, a]
        # each edge is planned as `plan` plans (refined): at most the matrix's search
        # energy between the same cells, and not far below it
        assert 0.85 * res.matrix_j[a, b] <= cost[a, b] <= 1.01 * res.matrix_j[a, b]
    assert cost[0, 1] > 1.2 * cost[1, 0]  # to the hilltop costs more than from it
    for k, leg in enumerate(res.legs):  # the tour's legs are its edges, unchanged
        meta = next(m for _, a, b, _, m in edges if (a, b) == (leg.a, leg.b))
        assert meta["tour_leg"] == k and meta["energy_j"] == cost[leg.a, leg.b] == leg.energy_j
        assert meta["duration_s"] == leg.duration_s
    for *_, c, m in edges:
        lo, hi = m["interval_j"]
        assert lo < c < hi and 0.0 <= m["battery_chance"] <= 1.0 and m["duration_s"] > 0


def test_mission_bag_has_one_topic_per_leg_with_running_stamps(tmp_path, hill_mission):
    prob, res = hill_mission
    res.write_bag(tmp_path / "m")
    msgs = _messages(tmp_path / "m")
    assert sorted(msgs) == [f"/energy_planner/mission/leg_{k}" for k in range(len(res.legs))]
    end = 0.0
    for k, leg in enumerate(res.legs):
        w = read_path_bag(tmp_path / "m", f"/energy_planner/mission/leg_{k}")
        (_, ns, _), = msgs[f"/energy_planner/mission/leg_{k}"]  # fmt: skip
        assert ns / 1e9 == pytest.approx(end, abs=2e-9)  # starts when the last leg ended
        pe = prob.path_energy(w.xy, yaw=w.yaw_rad, t=w.t)
        assert pe.energy_j == pytest.approx(leg.energy_j, rel=1e-9)
        end += leg.duration_s


def test_compare_routes_bag_has_one_topic_per_route(tmp_path):
    from energy_planner.planning.compare import compare_routes

    prob = Problem(_hill(), EnergyModel.default(), Request.make(speed=0.5))
    comp = compare_routes(prob, (500004.5, 5000004.5), (500030.5, 5000030.5), time=0.5,
                          progress=False)  # fmt: skip
    with pytest.raises(WaypointError, match="give the request"):  # planned at 0.5 m/s
        comp.write_bag(tmp_path / "wrong", request=Request())
    comp.write_bag(tmp_path / "r")  # with the terrain and request it was planned on
    msgs = _messages(tmp_path / "r")
    routes = [r for r in comp.routes if r.states is not None and r.energy_j is not None]
    assert sorted(msgs) == sorted(f"/energy_planner/routes/{r.name}" for r in routes)
    for r in routes:
        w = read_path_bag(tmp_path / "r", f"/energy_planner/routes/{r.name}")
        assert w.t[0] == 0.0 and w.t[-1] == pytest.approx(r.duration_s, abs=2e-9)
        pe = prob.unlimited().path_energy(w.xy, yaw=w.yaw_rad, t=w.t)
        assert pe.energy_j == pytest.approx(r.energy_j, rel=1e-9)
