"""Held-out evaluation: do the planned grasps hold on objects nobody tuned on?

    python bench/bench_holdout.py -o OUT --split test [--hands barrett,parallel_jaw] [--modes free,support]
        [--pool 10] [--trials 4] [--jobs 2] [--limit N] [--markdown FILE] [--plan-args "--verify-top 5 --verify lift"]
    python bench/bench_holdout.py -o OUT --table            # the tables again, from OUT/runs.jsonl
    python bench/bench_holdout.py -o OUT2 --plans-from OUT  # the same plans simulated again

For each object of the split (bench/objects.py: third-party meshes, dev or test by a hash of their
path), each hand and each mode (``free``: free-floating; ``support``: in its most likely resting pose
on a table, planned with ``--support``), the object is planned as a user plans it
(``pairgrasp plan --top POOL --seed 1 --pictures 0``) and **every** returned grasp is simulated
(``pairgrasp simulate --top POOL --trials 4 --seed 1``: trial 0 as planned, three with execution and
model errors). The plan's order is the default ranking's: its first grasp is what a user takes, its
first five are what ``--top 5`` returns.

Reported per hand and mode, with 95% bootstrap intervals over objects (an object without a
force-closure grasp counts 0):

- top-1 held: the rank-1 grasp's success rate over the trials;
- top-5 held: the mean success rate of ranks 1-5;
- the causes of the rank-1 grasp's failed trials, from the simulation (``failed_phase`` and the
  load that was on when the object left the thresholds; see docs/physics.md);
- pool rules: the rank-1 held rate had rank 1 been chosen within the same plan's grasps by another
  rule (the search's epsilon, load resistance, links in contact, opposition of the fingers'
  pushes; with ``--plan-args "--verify-top K ..."``, the plan's order before the simulation re-ranked
  it), with the change against the default's rank 1 on the same objects (paired bootstrap
  interval), and the best grasp of the pool (what a perfect ranking of these grasps would reach).
  Rules are compared on the dev half; the test half only reports.

A peer runs beside the hands: ``--hands parallel_jaw,gpg`` gives GPG (``bench/gpg_peer.py``, GPD's
antipodal candidate generator, installed by ``sh bench/install_gpg.sh``) the object's surface points and
the bundled jaw's geometry; its candidates, in its own order, go through the same physics check with
the same jaw (GPG does not rank them, so its rank 1 is its first candidate clear of the mesh). A peer's
grasp counts what the simulation says whether or not its contacts are force-closure. The table adds
the jaw's plan time over GPG's candidate generation time per object. ``approach_ray`` and ``random``
are the Barrett hand's baselines (``bench/baseline_peer.py``): OpenRAVE's approach-ray sampler, its
best by force closure then ε after 10 s of trials, and GraspIt!'s random approaches, in the order
drawn.

Every finished run is one JSON line of ``OUT/runs.jsonl`` (per grasp: its measures and every trial's
outcome); runs already there are skipped, so an interrupted benchmark resumes.
"""
from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor, as_completed

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import objects as objset  # noqa: E402
from bench_scenes import (HANDS, PLAN_ARGS, THIRD_PARTY_HANDS, bootstrap_mean, hands_and_modes, load_runs,  # noqa: E402
                          pairgrasp_cmd, plan_command, prepare, propose_third_party, reason_without_grasp, run_cmd)

MODES = ("free", "support")
#: Peers: planners that are not pairgrasp's, each with the bundled hand it grasps with.
PEERS = {"gpg": "parallel_jaw", "approach_ray": "barrett", "random": "barrett"}
#: The command line (in bench/) that writes a peer's grasps.json.
PEER_SCRIPTS = {"gpg": ["gpg_peer.py"], "approach_ray": ["baseline_peer.py", "approach_ray"],
                "random": ["baseline_peer.py", "random"]}
from bench_scenes import SEED  # noqa: E402  (the plan and the trials use the scene benchmark's seed)


# ----------------------------------------------------------------- grasp measures

def finger_measures(hand, grasp):
    """(opposition, drive) of a planned grasp from its recorded contacts. opposition is
    :func:`pairgrasp.closing_push`'s measures (recomputed here for files written before the
    planner recorded it): for each closing DOF, the push of the contacts it moves, opposed by how
    far those pushes cancel and by the most squarely opposed other contact; the least over the
    DOFs. drive is the least over the closing DOFs of the largest cosine between a contact's closing
    motion and its inward normal (1: the finger closes straight into the surface; near 0: it
    slides along it)."""
    from pairgrasp import _core

    W = np.asarray(grasp["wrist_pose"], float)
    Wi = np.linalg.inv(W)
    q = np.asarray(grasp["dof"], float)
    contacts = grasp.get("contacts") or []
    if not contacts:
        return -1.0, -1.0
    P = np.array([c["point"] for c in contacts], float)
    F = -np.array([c["normal"] for c in contacts], float)      # the hand's push on the object
    links = [c["link"] for c in contacts]
    T0 = hand.link_transforms(q)
    dirs = np.asarray(_core.closing_directions(hand, q))
    lo, hi = np.asarray(hand.dof_lower, float), np.asarray(hand.dof_upper, float)
    Pw = P @ Wi[:3, :3].T + Wi[:3, 3]
    worst = drive = None
    for k in range(len(q)):
        if dirs[k] == 0:
            continue
        q1 = q.copy()
        q1[k] = np.clip(q[k] + 1e-5 * dirs[k], lo[k], hi[k])
        if q1[k] == q[k]:
            q1[k] = q[k] - 1e-5 * dirs[k]                       # at the limit: the motion's direction is the same
        T1 = hand.link_transforms(q1)
        push = np.zeros(3)
        weight = 0.0
        best_drive = -1.0
        moved = np.zeros(len(P), bool)
        for c, name in enumerate(links):
            A = np.asarray(T1[name]) @ np.linalg.inv(np.asarray(T0[name]))
            d = (A[:3, :3] @ Pw[c] + A[:3, 3]) - Pw[c]
            n = np.linalg.norm(d)
            if n > 1e-12:
                moved[c] = True
                u = W[:3, :3] @ d / n * np.sign(q1[k] - q[k]) * dirs[k]
                push += F[c] * max(0.0, float(F[c] @ u))
                weight += max(0.0, float(F[c] @ u))
                best_drive = max(best_drive, float(F[c] @ u))
        if not moved.any() or weight <= 0:
            continue
        o = 1.0 - float(np.linalg.norm(push)) / weight
        if np.linalg.norm(push) > 1e-12 * weight and (~moved).any():
            o = max(o, float((F[~moved] @ -(push / np.linalg.norm(push))).max()))
        worst = o if worst is None else min(worst, o)
        drive = best_drive if drive is None else min(drive, best_drive)
    return (-1.0 if worst is None else worst), (-1.0 if drive is None else drive)


_CENTERS = {}


def target_center(path):
    """The target's centre of mass (m): the solid's when its mesh is closed, else its convex hull's."""
    import pairgrasp as pg
    from pairgrasp.inertia import hull_mass_properties

    if path not in _CENTERS:
        mesh = pg.load_mesh(path)
        try:
            props = pg.mass_properties(mesh, 1000.0)
        except ValueError:
            props = hull_mass_properties(np.asarray(mesh.vertices), 1000.0)
        _CENTERS[path] = np.asarray(props.center_of_mass, float)
    return _CENTERS[path]


def friction_needed(hand, grasp, center):
    """:func:`pairgrasp.closing_friction` of a planned grasp's recorded contacts (None without a
    contact a closing DOF moves; 99 when no friction up to 2 balances the fingers)."""
    import pairgrasp as pg

    contacts = grasp.get("contacts") or []
    if not contacts:
        return None
    mu = pg.closing_friction(hand, grasp["wrist_pose"], grasp["dof"], [c["point"] for c in contacts],
                             [c["normal"] for c in contacts], [c["link"] for c in contacts], center)
    return None if np.isnan(mu) else (99.0 if np.isinf(mu) else round(float(mu), 4))


def measures(hand, grasp, center=None) -> dict:
    contacts = grasp.get("contacts") or []
    opp, drive = finger_measures(hand, grasp)
    return {"rank": grasp.get("rank"), "planned_rank": grasp.get("planned_rank", grasp.get("rank")),
            "epsilon": grasp.get("epsilon"),
            "force_closure": bool(grasp.get("force_closure") and grasp.get("epsilon", 0) > 0),
            "load_resistance": grasp.get("load_resistance"),
            "links": len({c["link"] for c in contacts}),
            "palm": any(c["link"] == hand.wrist_link for c in contacts),
            "opposition": round(grasp["opposition"] if grasp.get("opposition") is not None else opp, 4),
            "drive": round(grasp["drive"] if grasp.get("drive") is not None else drive, 4),
            "friction_needed": None if center is None else friction_needed(hand, grasp, center),
            "dof": [round(float(v), 4) for v in grasp["dof"]],
            "approach": [round(float(v), 4) for v in np.asarray(grasp["wrist_pose"], float)[:3, :3]
                         @ np.asarray(hand.approach, float)]}


def trial_record(t) -> dict:
    keep = ("outcome", "success", "slip_translation", "slip_rotation", "closing_translation", "failed_phase",
            "contact_links")
    return {k: t.get(k) for k in keep}


# ----------------------------------------------------------------- one run

def one_run(obj, files, hand_name, mode, out, threads, pool, trials, timeout, plans_from=None):
    import pairgrasp as pg

    rec = {"object": obj.name, "rel": obj.rel, "split": obj.split, "hand": hand_name, "mode": mode,
           "height": round(files["height"], 6), "plan_time": None, "sim_wall": None, "grasps": [],
           "counts": {}, "error": None, "reason": None}
    peer_hand = PEERS.get(hand_name)
    if peer_hand is None:
        run_dir, cmd = plan_command(obj, files, hand_name, mode, out, threads, pool)
    else:
        run_dir = os.path.join(out, "runs", hand_name, mode, obj.name)
        os.makedirs(run_dir, exist_ok=True)
        script = PEER_SCRIPTS[hand_name]
        cmd = [sys.executable, os.path.join(HERE, script[0]), *script[1:], "--hand", HANDS[peer_hand], "--target",
               files["free"] if mode == "free" else files["rest"], "-o", run_dir, "--top", str(pool), "--seed", str(SEED)]
        if mode == "support":
            cmd.append("--support")
    gpath = os.path.join(run_dir, "grasps.json")
    if os.path.exists(gpath):
        os.remove(gpath)
    if plans_from is not None:               # the same plan simulated again (a change to the simulation)
        src = os.path.join(plans_from, "runs", hand_name, mode, obj.name, "grasps.json")
        if not os.path.exists(src):
            rec["error"], rec["reason"] = f"no plan in {plans_from}", "plan failed"
            return rec
        with open(src) as f:
            doc = json.load(f)
        for g in doc.get("grasps", []):
            g.pop("simulation", None)
        doc.pop("simulation", None)
        with open(gpath, "w") as f:
            json.dump(doc, f)
        err = None
    else:
        rc, wall, err, _ = run_cmd(cmd, timeout)
        rec["command_wall"] = round(wall, 3)     # the plan command's wall time, with --verify-top's simulations
    if err is not None:
        rec["error"], rec["reason"] = err, "plan failed"
        return rec
    with open(gpath) as f:
        doc = json.load(f)
    rec["plan_time"] = round(float(doc["timings"]["total"]), 4)
    if "gpg" in doc["timings"]:
        rec["generation_time"] = round(float(doc["timings"]["gpg"]), 4)
    rec["counts"] = doc.get("counts", {})
    if peer_hand is not None and not doc.get("grasps"):
        rec["reason"] = "no candidate clear of the mesh"
        return rec
    if peer_hand is None and not any(g.get("force_closure") and g.get("epsilon", 0) > 0 for g in doc.get("grasps", [])):
        rec["reason"] = reason_without_grasp(rec["counts"])
        return rec
    rc, wall, err, _ = run_cmd(pairgrasp_cmd("simulate", gpath, "--top", len(doc["grasps"]), "--trials", trials,
                                          "--seed", SEED, "--quiet", "--no-picture"), timeout)
    rec["sim_wall"] = round(wall, 3)
    if err is not None:
        rec["error"] = f"simulate: {err}"
        return rec
    with open(gpath) as f:
        doc = json.load(f)
    hand = _hand(hand_name)
    center = target_center(doc["inputs"]["target"])
    for g in doc["grasps"]:
        m = measures(hand, g, center)
        m["ungated"] = peer_hand is not None
        sim = g.get("simulation", {})
        m["held"] = sim.get("success_rate")
        m["trials"] = [trial_record(t) for t in sim.get("trials", [])]
        rec["grasps"].append(m)
    return rec


# ----------------------------------------------------------------- tables

def _fmt(x, spec=".2f"):
    return "–" if x is None else format(x, spec)


def _ci(values):
    m, lo, hi = bootstrap_mean(values)
    return f"{_fmt(m)} [{_fmt(lo)}, {_fmt(hi)}]" if m is not None else "–"


def held_of(g):
    """The grasp's held rate; 0 for a pairgrasp grasp that is not force-closure (the planner would not
    return it first), a peer's as simulated."""
    return float(g["held"]) if g and g.get("held") is not None and (g["force_closure"] or g.get("ungated")) else 0.0


#: Ways to pick rank 1 among a plan's grasps (each a key: the largest wins among force-closure grasps).
RULES = {
    "as planned (the default ranking's rank 1)": None,
    "the plan's order before plan --verify-top": lambda g: (-g.get("planned_rank", g["rank"]),),
    "largest epsilon": lambda g: (g["epsilon"],),
    "largest load resistance": lambda g: (g["load_resistance"] or 0.0, g["epsilon"]),
    "most links in contact, then epsilon": lambda g: (g["links"], g["epsilon"]),
    "opposition >= 0.5 first, then load resistance": lambda g: (g["opposition"] >= 0.5, g["load_resistance"] or 0.0),
    "opposition >= 0.7 first, then load resistance": lambda g: (g["opposition"] >= 0.7, g["load_resistance"] or 0.0),
    "largest opposition, then load resistance": lambda g: (round(g["opposition"], 2), g["load_resistance"] or 0.0),
    "drive >= 0.5 first, then load resistance": lambda g: (g["drive"] >= 0.5, g["load_resistance"] or 0.0),
    "opposition and drive >= 0.5 first, then load resistance":
        lambda g: (g["opposition"] >= 0.5 and g["drive"] >= 0.5, g["load_resistance"] or 0.0),
    "no palm contact first, then load resistance": lambda g: (not g["palm"], g["load_resistance"] or 0.0),
    "least friction needed at the closing, then load resistance":
        lambda g: (-(99.0 if g.get("friction_needed") is None else g["friction_needed"]), g["load_resistance"] or 0.0),
    "no palm contact, opposition and drive >= 0.5 first, then load resistance":
        lambda g: (not g["palm"] and g["opposition"] >= 0.5 and g["drive"] >= 0.5, g["load_resistance"] or 0.0),
}


def pick(grasps, rule):
    fc = [g for g in grasps if g["force_closure"]]
    if not fc:
        return None
    if rule is None:
        return grasps[0]
    return max(fc, key=rule)


def cause_of(trial, grasp, mode):
    """The measured cause of a failed trial (docs/physics.md): where the object left the thresholds."""
    phase = trial.get("failed_phase")
    if trial.get("outcome") == "slipped":
        return "slid in the hand (kept, beyond 10 mm or 11.5 deg)"
    if phase == "closing":
        return "pushed away while the fingers closed"
    if phase == "lift":
        return "fell as the table left (lift)" if mode != "free" else "fell as gravity came on"
    if phase is None:
        return "unknown (no phase recorded)"
    if phase.startswith("shake"):
        return "fell in the shake"
    d = {"-z": (0, 0, -1), "+z": (0, 0, 1), "+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0)}
    g = np.asarray(d[phase.split()[1]], float)
    a = np.asarray(grasp["approach"], float)
    along = float(g @ a)
    if along > 0.7:
        return "fell with gravity along the approach (pulled out of the hand)"
    if along < -0.7:
        return "fell with gravity into the palm"
    return "fell with gravity across the approach"


def tables(runs, hands, modes):
    lines = ["| hand | mode | split | objects | force closure | top-1 held [95% CI] | top-5 held [95% CI] "
             "| median plan (s) | median command (s) |", "|---|---|---|---|---|---|---|---|---|"]
    causes_lines, rule_lines = [], []
    for hand in hands:
        for mode in modes:
            for split in ("dev", "test"):
                rs = [r for r in runs if r["hand"] == hand and r["mode"] == mode and r["split"] == split]
                if not rs:
                    continue
                top1 = [held_of(r["grasps"][0]) if r["grasps"] else 0.0 for r in rs]
                top5 = [float(np.mean([held_of(g) for g in r["grasps"][:5]])) if r["grasps"] else 0.0 for r in rs]
                times = [r["plan_time"] for r in rs if r["plan_time"] is not None]
                walls = [r["command_wall"] for r in rs if r.get("command_wall") is not None]
                fc = sum(1 for r in rs if any(g["force_closure"] for g in r["grasps"]) or
                         (not r["grasps"] and r["reason"] is None and not r["error"]))
                lines.append(f"| {hand} | {mode} | {split} | {len(rs)} | {fc} | {_ci(top1)} | {_ci(top5)} "
                             f"| {_fmt(statistics.median(times) if times else None)} "
                             f"| {_fmt(statistics.median(walls) if walls else None)} |")
                counts = {}
                n_trials = 0
                for r in rs:
                    if not r["grasps"]:
                        counts[f"no force-closure grasp ({r['reason'] or r['error']})"] = \
                            counts.get(f"no force-closure grasp ({r['reason'] or r['error']})", 0) + 1
                        continue
                    g = r["grasps"][0]
                    for t in g["trials"]:
                        n_trials += 1
                        if not t["success"]:
                            c = cause_of(t, g, mode)
                            counts[c] = counts.get(c, 0) + 1
                causes_lines.append(f"**{hand}, {mode}, {split}** ({len(rs)} objects, {n_trials} rank-1 trials): "
                                    + "; ".join(f"{k}: {v}" for k, v in sorted(counts.items(), key=lambda kv: -kv[1])))
                # How far the object moved while the fingers closed in the unperturbed trial, over every
                # simulated grasp (docs/physics.md: it moves even where the planned contacts balance).
                moves = [g["trials"][0]["closing_translation"] for r in rs for g in r["grasps"]
                         if g["trials"] and g["trials"][0].get("closing_translation") is not None
                         and (g["force_closure"] or g.get("ungated"))]
                if moves:
                    causes_lines.append(f"closing move in the unperturbed trial ({len(moves)} grasps): median "
                                        f"{1000 * statistics.median(moves):.1f} mm, "
                                        f"{100 * np.mean(np.asarray(moves) > 0.005):.0f}% over 5 mm")
                if hand in PEERS:   # the rules order pairgrasp's plans; a peer keeps its own order
                    continue
                row = []
                planned = np.array([held_of(pick(r["grasps"], None)) if r["grasps"] else 0.0 for r in rs])
                for name, rule in RULES.items():
                    v = np.array([held_of(pick(r["grasps"], rule)) if r["grasps"] else 0.0 for r in rs])
                    # the change against the default's rank 1 on the same objects (paired bootstrap)
                    dm, dlo, dhi = bootstrap_mean(v - planned)
                    row.append(_ci(v) + ("" if rule is None else f"; {dm:+.2f} [{dlo:+.2f}, {dhi:+.2f}]"))
                best = [max((held_of(g) for g in r["grasps"]), default=0.0) for r in rs]
                rule_lines.append(f"| {hand} | {mode} | {split} | " + " | ".join(row) + f" | {_ci(best)} |")
    for peer, jaw in PEERS.items():
        for mode in modes:
            for split in ("dev", "test"):
                gen = {r["object"]: r.get("generation_time") for r in runs
                       if r["hand"] == peer and r["mode"] == mode and r["split"] == split}
                plan = {r["object"]: r["plan_time"] for r in runs
                        if r["hand"] == jaw and r["mode"] == mode and r["split"] == split}
                ratios = [plan[o] / gen[o] for o in gen if gen[o] and plan.get(o)]
                if ratios:
                    lines.append(f"\n{jaw} plan time / {peer} candidate generation time, {mode}, {split} "
                                 f"({len(ratios)} objects): median {statistics.median(ratios):.1f}x, "
                                 f"max {max(ratios):.1f}x; {peer} generation median "
                                 f"{statistics.median([gen[o] for o in gen if gen[o]]):.2f} s")
    head = ["| hand | mode | split | " + " | ".join(RULES) + " | best of the plan |",
            "|---|---|---|" + "---|" * (len(RULES) + 1)]
    return lines, causes_lines, head + rule_lines


def refresh(rec, out):
    """The record's per-grasp measures and outcomes read again from its grasps.json (when it is
    there), so that measures added since the run are in the tables."""
    import pairgrasp as pg

    gpath = os.path.join(out, "runs", rec["hand"], rec["mode"], rec["object"], "grasps.json")
    if not rec["grasps"] or not os.path.exists(gpath):
        return rec
    with open(gpath) as f:
        doc = json.load(f)
    hand = _hand(rec["hand"])
    center = target_center(doc["inputs"]["target"])
    grasps = []
    for g in doc["grasps"]:
        m = measures(hand, g, center)
        m["ungated"] = rec["hand"] in PEERS
        sim = g.get("simulation", {})
        m["held"] = sim.get("success_rate")
        m["trials"] = [trial_record(t) for t in sim.get("trials", [])]
        grasps.append(m)
    return {**rec, "grasps": grasps}


_HANDS = {}


def _hand(name):
    import pairgrasp as pg

    if name not in _HANDS:
        _HANDS[name] = pg.load_hand(HANDS[PEERS.get(name, name)])
    return _HANDS[name]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--split", choices=["test", "dev", "all"], default="test")
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--hands", default="barrett")
    ap.add_argument("--modes", default=",".join(MODES))
    ap.add_argument("--pool", type=int, default=10, help="grasps planned and simulated per run")
    ap.add_argument("--trials", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--timeout", type=float, default=900.0)
    ap.add_argument("--table", action="store_true", help="print the tables of OUT/runs.jsonl and stop")
    ap.add_argument("--plans-from", default=None, metavar="DIR",
                    help="simulate the plans of an earlier run's folder again instead of planning")
    ap.add_argument("--markdown", default=None)
    ap.add_argument("--plan-args", default="", metavar="ARGS",
                    help="more `pairgrasp plan` options for every plan, e.g. \"--verify-top 10 --verify lift\"")
    args = ap.parse_args(argv)
    PLAN_ARGS[:] = shlex.split(args.plan_args)
    hands, modes = hands_and_modes(ap, args.hands, args.modes, MODES, peers=PEERS)
    os.makedirs(args.out, exist_ok=True)
    for h in hands:
        if h in THIRD_PARTY_HANDS:
            propose_third_party(h, args.out)
    runs_path = os.path.join(args.out, "runs.jsonl")
    done = load_runs(runs_path)
    if not args.table:
        threads = args.threads or max(1, (os.cpu_count() or 1) // max(1, args.jobs))
        objs = objset.load_objects(None if args.split == "all" else args.split)
        if args.limit is not None:
            objs = objs[:args.limit]
        todo = [(o, h, m) for o in objs for h in hands for m in modes if (o.name, h, m) not in done]
        print(f"{len(objs)} objects ({args.split}): {len(todo)} run(s) to do, {args.jobs} at once", flush=True)
        mesh_dir = os.path.join(args.out, "meshes")
        files = {}
        for o in {o.name: o for o, _, _ in todo}.values():
            files[o.name] = prepare(o, mesh_dir)
        lock = threading.Lock()
        t0 = time.perf_counter()

        def work(o, h, m):
            r = one_run(o, files[o.name], h, m, args.out, threads, args.pool, args.trials, args.timeout,
                        args.plans_from)
            with lock:
                with open(runs_path, "a") as f:
                    f.write(json.dumps(r) + "\n")
            return r

        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as ex:
            futs = [ex.submit(work, *t) for t in todo]
            for k, fut in enumerate(as_completed(futs), 1):
                r = fut.result()
                g1 = r["grasps"][0] if r["grasps"] else None
                print(f"[{k}/{len(todo)}] {r['object']} {r['hand']} {r['mode']}: "
                      + (f"top-1 held {_fmt(held_of(g1))}, top-5 {np.mean([held_of(g) for g in r['grasps'][:5]]):.2f}"
                         if g1 else (r["reason"] or r["error"] or "no grasp"))
                      + f" ({time.perf_counter() - t0:.0f} s)", flush=True)
        done = load_runs(runs_path)
    runs = [refresh(r, args.out) for r in done.values()]
    main_lines, cause_lines, rule_lines = tables(runs, hands, modes)
    text = "\n".join(main_lines + [""] + cause_lines + [""] + rule_lines)
    print(text)
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
