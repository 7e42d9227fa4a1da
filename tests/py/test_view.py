"""`pairgrasp view`: the glTF export read back with trimesh, the errors, and the interactive viewer
loaded in a real headless browser (Debian's chromium) and checked to have drawn the scene."""
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import pairgrasp as pg

trimesh = pytest.importorskip("trimesh")

MODELS = pathlib.Path(__file__).resolve().parents[2] / "models"
JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"
BOX = MODELS / "targets" / "box.stl"
BOX_PAINT = MODELS / "targets" / "box.paint.json"


def run(*args, code=None):
    cmd = [sys.executable, "-m", "pairgrasp.cli", *args] if code is None else [sys.executable, "-c", code, *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def jaw_grasps(tmp_path_factory):
    """A real plan: the parallel jaw on the box with its paint (2 of 12 faces occluded), 2 grasps,
    written as `pairgrasp plan` writes it, with a simulation outcome added to rank 1."""
    planner = pg.Planner(str(JAW), str(BOX), paint=str(BOX_PAINT), edge=0.008, top=2, seed=0)
    result = planner.plan(progress=False)
    assert len(result.grasps) == 2
    doc = result.to_dict()
    doc["grasps"][0]["simulation"] = {"success": True, "outcome": "held", "slip_translation": 0.0012,
                                      "slip_rotation": 0.01}
    path = tmp_path_factory.mktemp("view") / "grasps.json"
    pg.write_grasps(path, doc)
    return path, planner, result


def _world(scene, node):
    T, geom = scene.graph.get(node)
    return np.asarray(T, float), geom


def test_export_holds_the_target_and_the_hand_at_the_grasp(jaw_grasps, tmp_path):
    path, planner, result = jaw_grasps
    out = tmp_path / "scene.glb"
    r = run("view", str(path), "--export", str(out))
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and "rank 1" in r.stdout
    s = trimesh.load(out)
    hand = pg.load_hand(str(JAW))
    links = [link for link in hand.links if link.mesh is not None and len(link.mesh.faces)]
    names = {"target", "target/occluded", "grasp1/contacts", "grasp1/normals"} | {f"grasp1/{l.name}" for l in links}
    assert set(s.geometry) == names

    # The target as loaded from the file: pairgrasp's and trimesh's vertex counts of box.stl.
    mesh = pg.load_mesh(str(BOX))
    assert len(s.geometry["target"].vertices) == len(mesh.vertices) == len(trimesh.load(BOX).vertices)
    T, _ = _world(s, "target")
    assert np.allclose(T, np.eye(4))
    free = np.asarray(pg.load_paint(str(BOX_PAINT), mesh), bool)
    assert len(s.geometry["target/occluded"].faces) == int((~free).sum()) == 2

    # Each link node sits at wrist_pose @ Hand.link_poses(dofs), computed here, with the link mesh
    # in its own frame: the exported vertices, posed, are the link's vertices posed by the hand.
    g = result.grasps[0]
    poses = np.asarray(hand.link_poses(np.asarray(g.dofs), clamp=True))
    by_name = {l.name: k for k, l in enumerate(hand.links)}
    for link in links:
        W = np.asarray(g.wrist_pose) @ poses[by_name[link.name]]
        T, geom = _world(s, f"grasp1/{link.name}")
        assert geom == f"grasp1/{link.name}"
        assert np.allclose(T, W, atol=1e-9), link.name
        v = np.asarray(s.geometry[geom].vertices, float)
        want = np.asarray(link.mesh.vertices, float) @ W[:3, :3].T + W[:3, 3]
        assert np.allclose(v @ T[:3, :3].T + T[:3, 3], want, atol=1e-6), link.name

    # One 80-face sphere per contact, centred on it; the grasp's numbers in the scene's extras.
    spheres = s.geometry["grasp1/contacts"]
    assert len(spheres.faces) == 80 * len(g.contact_points)
    centres = np.asarray(spheres.vertices, float).reshape(len(g.contact_points), -1, 3).mean(axis=1)
    assert np.allclose(centres, g.contact_points, atol=1e-6)
    extras = s.metadata["grasps"]
    assert [e["rank"] for e in extras] == [1]
    assert extras[0]["epsilon"] == pytest.approx(g.epsilon)
    assert extras[0]["simulation"]["outcome"] == "held"


@pytest.mark.long
def test_export_rank_and_all_ranks(jaw_grasps, tmp_path):
    path, _, _ = jaw_grasps
    r = run("view", str(path), "--export", str(tmp_path / "two.glb"), "--rank", "2")
    assert r.returncode == 0, r.stderr
    names = set(trimesh.load(tmp_path / "two.glb").geometry)
    assert any(n.startswith("grasp2/") for n in names) and not any(n.startswith("grasp1/") for n in names)
    r = run("view", str(path), "--export", str(tmp_path / "all.glb"), "--rank", "all")
    assert r.returncode == 0, r.stderr
    s = trimesh.load(tmp_path / "all.glb")
    assert {"grasp1/contacts", "grasp2/contacts"} <= set(s.geometry)
    assert [e["rank"] for e in s.metadata["grasps"]] == [1, 2]


def test_scene_text_has_epsilon_and_the_simulation(jaw_grasps):
    from pairgrasp import view

    path, _, result = jaw_grasps
    scene = view.load_scene(path)
    assert [g.rank for g in scene.grasps] == [1, 2]
    one, two = scene.grasps
    assert f"ε {result.grasps[0].epsilon:.4f}" in one.summary and "simulated: held (slip 1.20 mm" in one.summary
    assert "force closure" in two.summary and "simulated" not in two.summary


@pytest.mark.long
def test_obstacles_and_occluders_are_in_the_scene(tmp_path):
    """A plan with a table as obstacle and occluder: the exported scene holds both, and the occluded
    faces it rebuilds from the recorded files are the planner's (no note about a difference)."""
    from pairgrasp import view

    table = trimesh.creation.box(bounds=[[-0.2, -0.2, -0.02], [0.2, 0.2, 0.0]])
    table.export(str(tmp_path / "table.stl"))
    box = trimesh.creation.box(bounds=[[-0.03, -0.03, 0.0], [0.03, 0.03, 0.12]]).subdivide()
    box.export(str(tmp_path / "box.stl"))
    planner = pg.Planner(str(JAW), str(tmp_path / "box.stl"), obstacles=[str(tmp_path / "table.stl")],
                         occluders=[str(tmp_path / "table.stl")], edge=0.008, top=1, seed=0)
    result = planner.plan(progress=False)
    pg.write_grasps(tmp_path / "grasps.json", result.to_dict())
    scene = view.load_scene(tmp_path / "grasps.json")
    assert scene.notes == []
    s = view.to_trimesh(scene)
    assert {"target", "target/occluded", "obstacle1", "occluder1"} <= set(s.geometry)
    assert len(s.geometry["target/occluded"].faces) == int((~np.asarray(planner.free)).sum()) > 0


def _one_line_error(r, needle, code=1):
    assert r.returncode == code, (r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pairgrasp: error:"), r.stderr
    assert "Traceback" not in r.stderr
    assert needle in lines[0], lines[0]


def test_errors_are_one_line(jaw_grasps, tmp_path):
    path, _, _ = jaw_grasps
    out = str(tmp_path / "x.glb")
    _one_line_error(run("view", str(tmp_path / "none.json"), "--export", out), "none.json: cannot read")
    bad = tmp_path / "cut.json"
    bad.write_text(path.read_text()[:200])
    _one_line_error(run("view", str(bad), "--export", out), "cut.json: not valid JSON")
    doc = json.loads(path.read_text())
    doc["inputs"]["target"] = str(tmp_path / "gone.stl")
    moved = tmp_path / "moved.json"
    moved.write_text(json.dumps(doc))
    _one_line_error(run("view", str(moved), "--export", out), "inputs.target: no such file")
    _one_line_error(run("view", str(path), "--export", out, "--hand", str(MODELS / "barrett" / "barrett.json")),
                    "planned for hand 'parallel_jaw'")
    _one_line_error(run("view", str(path), "--export", str(tmp_path / "scene.obj")), "expected a .glb file name")
    _one_line_error(run("view", str(path), "--export", out, "--rank", "7"), "no grasp of rank 7 (ranks: 1, 2)")
    _one_line_error(run("view", str(path), "--rank", "0"), "--rank", code=2)
    _one_line_error(run("view", str(path), "--port", "70000"), "--port", code=2)
    assert not os.path.exists(out)


def test_missing_viser_is_one_line_naming_the_extra(jaw_grasps, tmp_path):
    path, _, _ = jaw_grasps
    block = "import sys; sys.modules['viser'] = None; from pairgrasp.cli import main; sys.exit(main(sys.argv[1:]))"
    _one_line_error(run("view", str(path), code=block), "pip install pairgrasp[view]")
    r = run("view", str(path), "--export", str(tmp_path / "ok.glb"), code=block)     # export needs no viser
    assert r.returncode == 0, r.stderr


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        exe = shutil.which(name)
        if exe:
            return exe
    return None


class _Browser:
    """Headless chromium driven over the DevTools protocol (a websocket): WebGL on SwiftShader,
    screenshots on demand. `--screenshot` alone takes its picture after a virtual-time budget, which
    with cached assets can come before the page has drawn; here the test polls instead."""

    def __init__(self, exe, profile, size=(1000, 700)):
        import urllib.request

        from websockets.sync.client import connect

        self.proc = subprocess.Popen(
            [exe, "--headless", "--no-sandbox", "--disable-gpu", "--use-gl=angle", "--use-angle=swiftshader",
             "--enable-unsafe-swiftshader", "--hide-scrollbars", "--no-first-run", "--remote-allow-origins=*",
             "--remote-debugging-port=0", f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}",
             "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
            env={k: v for k, v in os.environ.items() if k != "LD_PRELOAD"})     # not the sanitized run's ASan
        t0, port = time.monotonic(), None
        while port is None and time.monotonic() - t0 < 60:
            line = self.proc.stderr.readline()
            if not line:
                break
            if "DevTools listening on ws://" in line:
                port = line.split("ws://", 1)[1].split("/", 1)[0].rsplit(":", 1)[1]
        assert port, "chromium did not start its DevTools server"
        pages = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30))
        page = next(p for p in pages if p.get("type") == "page")
        self.ws = connect(page["webSocketDebuggerUrl"], max_size=None, open_timeout=30)
        self.next_id = 0
        self.call("Emulation.setDeviceMetricsOverride", width=size[0], height=size[1], deviceScaleFactor=1,
                  mobile=False)

    def call(self, method, **params):
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv(timeout=60))
            if msg.get("id") == self.next_id:
                assert "error" not in msg, msg
                return msg.get("result", {})

    def screenshot(self):
        import base64
        import io

        from PIL import Image

        png = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), int), png

    def close(self):
        try:
            self.ws.close()
        finally:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def _drawn(img):
    """Pixels of the scene in the 3-D canvas: left of viser's control panel (right, ~330 px) and below
    its notice (top left): the hand's shaded blue and the occluded faces' shaded orange."""
    canvas = img[200:, :640].reshape(-1, 3)
    r, g, b = canvas.T
    hand = int(((b > r + 40) & (b > g + 20)).sum())
    occluded = int(((r > b + 60) & (r > 100) & (g > 40) & (r > g + 40) & (g > b + 20)).sum())  # lit or shaded orange
    return dict(std=float(canvas.std()), colours=len(np.unique(canvas, axis=0)), hand=hand, occluded=occluded)


@pytest.mark.long
def test_viewer_draws_in_a_headless_browser(jaw_grasps, tmp_path):
    """Serves the scene on a free port, loads the page in headless chromium (WebGL on SwiftShader) and
    checks a screenshot of the 3-D canvas: not blank, the hand's blue and the occluded faces' orange in
    it (the camera looks from below so the box's painted bottom is in view)."""
    pytest.importorskip("viser", reason="viser is not installed (pip install .[view]; scripts/install_deps.sh does)")
    pytest.importorskip("websockets", reason="websockets (a viser dependency) is not installed")
    pytest.importorskip("PIL", reason="Pillow (a matplotlib dependency) is not installed")
    exe = _chromium()
    if exe is None:
        pytest.skip("no chromium on PATH (apt-get install chromium; scripts/install_deps.sh does)")
    path, _, _ = jaw_grasps
    # The server's output goes to files: a pipe nobody reads while the page is drawn fills up and
    # blocks the server, which then cannot stop.
    out, err = tmp_path / "server.out", tmp_path / "server.err"
    with open(out, "w") as fo, open(err, "w") as fe:
        # SIGINT back to its default in the server: a shell that runs the tests in the background
        # starts them with SIGINT ignored, which the server would inherit and keep.
        server = subprocess.Popen([sys.executable, "-m", "pairgrasp.cli", "view", str(path), "--port", "0"],
                                  stdout=fo, stderr=fe, stdin=subprocess.DEVNULL, text=True,
                                  preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    browser = None
    try:
        url, t0 = None, time.monotonic()
        while url is None and time.monotonic() - t0 < 120 and server.poll() is None:
            time.sleep(0.2)
            for line in out.read_text().splitlines():
                if line.startswith("viewing "):
                    url = line.split(" at ", 1)[1].split()[0]
        assert url, f"the viewer printed no URL: {err.read_text()[-2000:]}"
        browser = _Browser(exe, tmp_path / "profile")
        # From below the box: its occluded bottom faces face the camera.
        browser.call("Page.navigate", url=url + "/?initialCameraPosition=0.12,-0.16,-0.1&initialCameraLookAt=0,0,0.03")
        seen, t0 = {}, time.monotonic()
        while time.monotonic() - t0 < 150:
            time.sleep(2.0)
            img, png = browser.screenshot()
            seen = _drawn(img)
            if seen["hand"] > 2000 and seen["occluded"] > 200:
                break
        (tmp_path / "shot.png").write_bytes(png)
        assert img.shape == (700, 1000, 3)
        assert seen["std"] > 10 and seen["colours"] > 200, f"blank canvas: {seen}"
        assert seen["hand"] > 2000, f"no hand in the canvas: {seen} (screenshot {tmp_path / 'shot.png'})"
        assert seen["occluded"] > 200, f"no occluded faces in the canvas: {seen} (screenshot {tmp_path / 'shot.png'})"
    finally:
        if browser is not None:
            browser.close()
        server.send_signal(signal.SIGINT)
        try:
            code = server.wait(timeout=60)
        except subprocess.TimeoutExpired:
            server.kill()
            code = server.wait()
    assert code == 0
