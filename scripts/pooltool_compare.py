#!/usr/bin/env python3
"""pooltool_compare.py — the slide_roll law against pooltool, shot by shot.

    HOME=build/pt-home build/pt-venv/bin/python scripts/pooltool_compare.py \
        POOLREPS OUT.csv [--shots N] [--seed S]

Builds poolreps' table in pooltool (four straight cushion lines at the table's
edges, so a ball centre turns R from them, and six capture circles of radius
0.03 m at the pocket centres), with frictionless ball-ball collisions and
pooltool's "unrealistic" mirror cushion (normal velocity times -e_c, spin
kept), e_c = kappa = 0.8, u_s = 0.2, u_r = 0.01, g = 9.81, R = 0.015, and
strikes the cue ball with a velocity and no spin (a stun shot). Shots come in
three families: random (cue and object ball anywhere, direction and speed
0.05-2 m/s uniform), Experiment 3's start region with its initial policy
N(0, 0.1^2 I), and the ghost-ball expert's shots from Experiment 2's region
(its aim and its speed under slide_roll, from the equations here). For each shot it writes one CSV row: family,
the inputs, poolreps' and pooltool's pocket of each ball and final positions.
pooltool writes its settings under $HOME/.config/pooltool on import: set HOME
to a folder under build/."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import io
import math
import subprocess
import sys

import numpy as np

L, W, R, RP = 1.0, 0.5, 0.015, 0.03
MS, MR, KAPPA, G = 0.2, 0.01, 0.8, 9.81
POCKETS = [((k % 3 - 1) * L / 2, (-1 if k < 3 else 1) * W / 2) for k in range(6)]


def pooltool_system(state, action):
    import pooltool as pt
    from pooltool.objects.table.components import (CushionSegments, LinearCushionSegment,
                                                   Pocket)
    from pooltool.objects.table.datatypes import Table, TableType

    # pooltool's frame: the table's corner at the origin
    ox, oy = L / 2, W / 2
    h = 0.64 * 2 * R  # the cushions' nose height (ignored by the mirror model)
    corners = [(0, 0), (L, 0), (L, W), (0, W)]
    lin = {}
    for k in range(4):
        (x1, y1), (x2, y2) = corners[k], corners[(k + 1) % 4]
        lin[str(k)] = LinearCushionSegment(str(k), p1=np.array([x1, y1, h]),
                                           p2=np.array([x2, y2, h]))
    pockets = {str(k): Pocket(str(k), center=np.array([px + ox, py + oy, 0.0]), radius=RP)
               for k, (px, py) in enumerate(POCKETS)}
    table = Table(cushion_segments=CushionSegments(linear=lin, circular={}), pockets=pockets,
                  table_type=TableType.POCKET)
    balls = {}
    for i in range(len(state) // 2):
        b = pt.Ball.create(str(i), xy=(state[2 * i] + ox, state[2 * i + 1] + oy), R=R, u_s=MS,
                           u_r=MR, e_c=KAPPA, g=G)
        balls[str(i)] = b
    cue = balls["0"]
    cue.state.rvw[1] = np.array([action[0], action[1], 0.0])
    cue.state.s = pt.constants.sliding
    return pt.System(cue=pt.Cue(cue_ball_id="0"), table=table, balls=balls)


def engine():
    import pooltool as pt
    from pooltool.physics.resolve.resolver import Resolver, ResolverConfig
    from pooltool.physics.resolve.ball_ball import BallBallModel
    from pooltool.physics.resolve.ball_cushion import BallCCushionModel, BallLCushionModel
    from pooltool.physics.resolve.ball_pocket import BallPocketModel
    from pooltool.physics.resolve.stick_ball import StickBallModel
    from pooltool.physics.resolve.transition import BallTransitionModel

    cfg = ResolverConfig(
        ball_ball=BallBallModel.FRICTIONLESS_ELASTIC, ball_ball_params={},
        ball_linear_cushion=BallLCushionModel.UNREALISTIC, ball_linear_cushion_params={},
        ball_circular_cushion=BallCCushionModel.UNREALISTIC, ball_circular_cushion_params={},
        ball_pocket=BallPocketModel.CANONICAL, ball_pocket_params={},
        stick_ball=StickBallModel.INSTANTANEOUS_POINT, stick_ball_params={"throttle_english": True},
        transition=BallTransitionModel.CANONICAL, transition_params={})
    return pt.physics.PhysicsEngine(resolver=Resolver.from_config(cfg))


def run_pooltool(eng, state, action):
    import pooltool as pt
    system = pooltool_system(state, action)
    pt.simulate(system, engine=eng, inplace=True)
    out, pk = [], []
    for i in range(len(state) // 2):
        b = system.balls[str(i)]
        hit = b.state.s == pt.constants.pocketed
        pid = -1
        if hit:
            x, y = b.history[-1].rvw[0][:2] if len(b.history) else b.state.rvw[0][:2]
            pid = min(range(6), key=lambda k: math.hypot(x - L / 2 - POCKETS[k][0],
                                                          y - W / 2 - POCKETS[k][1]))
            out += list(POCKETS[pid])
        else:
            out += [b.state.rvw[0][0] - L / 2, b.state.rvw[0][1] - W / 2]
        pk.append(pid)
    return out, pk


def run_poolreps(binary, rows):
    text = "x0,y0,x1,y1,vx,vy\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows)
    r = subprocess.run([binary, "shoot", "--set", "table.friction_law=slide_roll"], input=text,
                       capture_output=True, text=True)
    if r.returncode:
        sys.exit(f"pooltool_compare: poolreps shoot: {r.stderr.strip()}")
    got = []
    for c in csv.DictReader(io.StringIO(r.stdout)):
        got.append(([float(c[k]) for k in ("x0", "y0", "x1", "y1")],
                    [int(c["pocket0"]), int(c["pocket1"])]))
    return got


def valid(st):
    if math.hypot(st[2] - st[0], st[3] - st[1]) < 2 * R:
        return False
    return all(math.hypot(st[2 * i] - px, st[2 * i + 1] - py) > RP
               for i in range(2) for px, py in POCKETS)


def shots(rng, n):
    hx, hy = L / 2 - R, W / 2 - R
    rows = []
    while len([r for r in rows if r[0] == "random"]) < n:
        st = [rng.uniform(-hx, hx), rng.uniform(-hy, hy), rng.uniform(-hx, hx),
              rng.uniform(-hy, hy)]
        if valid(st):
            a, v = rng.uniform(0, 2 * math.pi), rng.uniform(0.05, 2.0)
            rows.append(("random", st + [v * math.cos(a), v * math.sin(a)]))
    while len([r for r in rows if r[0] == "exp3"]) < n:
        st = [-0.25, 0.0, rng.uniform(0.05, 0.15), rng.uniform(-0.1, 0.1)]
        rows.append(("exp3", st + list(rng.normal(0, 0.1, 2))))
    return rows


def stun_speed(v, d):
    """Speed a stun ball needs to still have v after distance d (slide, then roll)."""
    v0 = math.sqrt(v * v + 2 * MS * G * d)
    if 7 * v >= 5 * v0:
        return v0
    return math.sqrt((v * v + 2 * MR * G * d) / ((25 + 24 * MR / MS) / 49))


def ghost_shots(rng, n, arrival=0.05):
    """The ghost-ball expert (aim at the centre of the target pocket, 2 or 5,
    nearest the object ball; the speed for the object ball to arrive there at
    arrival m/s under slide_roll) from Experiment 2's start region (cue ball
    at (-0.25, 0), object ball in [0.05, 0.45] x [-0.2, 0.2])."""
    rows = []
    while len(rows) < n:
        st = [-0.25, 0.0, rng.uniform(0.05, 0.45), rng.uniform(-0.2, 0.2)]
        if not valid(st):
            continue
        c, r = np.array(st[:2]), np.array(st[2:])
        p = min((np.array(POCKETS[k]) for k in (2, 5)), key=lambda q: np.linalg.norm(q - r))
        u = (p - r) / np.linalg.norm(p - r)
        g = r - 2 * R * u
        d = (g - c) / np.linalg.norm(g - c)
        cos = d @ u
        if cos <= 0:
            continue
        v0 = stun_speed(stun_speed(arrival, np.linalg.norm(p - r)) / cos, np.linalg.norm(g - c))
        rows.append(("ghost", st + list(v0 * d)))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("poolreps")
    ap.add_argument("out")
    ap.add_argument("--shots", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    rows = shots(rng, a.shots) + ghost_shots(rng, a.shots)
    got = run_poolreps(a.poolreps, [r for _, r in rows])
    eng = engine()
    with open(a.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["family", "x0", "y0", "x1", "y1", "vx", "vy", "pr_pocket0", "pr_pocket1",
                    "pt_pocket0", "pt_pocket1", "pr_x0", "pr_y0", "pr_x1", "pr_y1", "pt_x0", "pt_y0",
                    "pt_x1", "pt_y1"])
        for (fam, row), (pr_fin, pr_pk) in zip(rows, got):
            pt_fin, pt_pk = run_pooltool(eng, row[:4], row[4:])
            w.writerow([fam] + [repr(v) for v in row] + pr_pk + pt_pk +
                       [repr(v) for v in pr_fin] + [repr(float(v)) for v in pt_fin])
    return 0


if __name__ == "__main__":
    sys.exit(main())
