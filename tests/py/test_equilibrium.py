"""pairgrasp.closing_friction against friction worked out by hand: a wedge squeezed by the parallel
jaw needs tan(half its angle), a Barrett finger pressing an object against the palm needs tan of the
palm contact's tilt, one finger pushing alone cannot be balanced, and nothing pushed gives nan."""
import math

import numpy as np
import pytest

import pairgrasp as pg
from conftest import BARRETT, MODELS

JAW = MODELS / "parallel_jaw" / "parallel_jaw.json"


def _point_motion(hand, q, link, point, k, delta=1e-6):
    """Velocity of `point` (wrist frame, fixed to `link`) per unit closing of DOF k, by central
    differences of Hand.link_transforms."""
    sign = int(np.asarray(pg.closing_directions(hand, q)).ravel()[k])
    out = []
    for s in (-delta, delta):
        q1 = np.array(q, float)
        q1[k] += s * sign
        out.append(np.asarray(hand.link_transforms(q1)[link]))
    t0 = np.asarray(hand.link_transforms(np.asarray(q, float))[link])
    local = np.linalg.inv(t0) @ np.append(point, 1.0)
    return ((out[1] - out[0]) @ local)[:3] / (2 * delta)


def _tilted(u, axis, angle):
    """u turned by `angle` about the unit `axis` (Rodrigues)."""
    return u * math.cos(angle) + np.cross(axis, u) * math.sin(angle) + axis * (axis @ u) * (1 - math.cos(angle))


def _jaw_contacts(hand, q):
    """A point on each pad's face at the pads' mid-height, and the closing direction of each."""
    points, motions = [], []
    for link in ("pj_left_finger", "pj_right_finger"):
        t = np.asarray(hand.link_transforms(q)[link])
        p = t[:3, 3]
        points.append(p)
        motions.append(_point_motion(hand, q, link, p, 0))
    return np.array(points), np.array(motions)


@pytest.mark.parametrize("half_angle_deg", [0.0, 10.0, 20.0, 35.0])
def test_a_wedge_between_the_jaws_needs_tan_of_its_half_angle(half_angle_deg):
    hand = pg.load_hand(str(JAW))
    q = np.array([0.5 * (hand.dof_lower[0] + hand.dof_upper[0])])
    p, v = _jaw_contacts(hand, q)
    u = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])       # from the left pad to the right one
    assert v[0] @ u > 0 and v[1] @ u < 0                   # the pads close toward each other
    side = np.cross(u, np.asarray(hand.approach, float))
    side /= np.linalg.norm(side)
    a = math.radians(half_angle_deg)
    # The wedge's faces lean toward each other: each outward normal is the pad's push turned by a
    # about the same axis, so the squeeze along the line between the pads is tan(a) off each normal.
    normals = np.array([_tilted(-u, side, a), _tilted(u, side, -a)])
    center = p.mean(0)
    mu = pg.closing_friction(hand, np.eye(4), q, p, normals, ["pj_left_finger", "pj_right_finger"], center,
                             edges=64, tolerance=1e-4)
    # 64 pyramid edges lie within 1 / cos(pi / 64) - 1 = 0.12% of the cone
    assert mu == pytest.approx(math.tan(a), rel=2e-3, abs=2e-4)
    # the answer does not depend on where the grasp is: moved and turned rigidly, the same
    rot = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    w = np.eye(4)
    w[:3, :3], w[:3, 3] = rot, [0.3, -0.2, 0.1]
    moved = pg.closing_friction(hand, w, q, p @ rot.T + w[:3, 3], normals @ rot.T,
                                ["pj_left_finger", "pj_right_finger"], rot @ center + w[:3, 3], edges=64,
                                tolerance=1e-4)
    assert moved == pytest.approx(math.tan(a), rel=2e-3, abs=2e-4)


def test_one_pad_alone_cannot_be_balanced_and_no_contact_gives_nan():
    hand = pg.load_hand(str(JAW))
    q = np.array([0.02])
    p, v = _jaw_contacts(hand, q)
    u = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
    assert pg.closing_friction(hand, np.eye(4), q, p[:1], [-u], ["pj_left_finger"], p[0] + 0.01 * u) == math.inf
    assert math.isnan(pg.closing_friction(hand, np.eye(4), q, np.zeros((0, 3)), np.zeros((0, 3)), [], p[0]))


@pytest.mark.parametrize("tilt_deg", [0.0, 15.0, 30.0])
def test_a_barrett_finger_pressing_against_the_palm_needs_tan_of_the_palm_contacts_tilt(tilt_deg):
    # Finger 3's fingertip pushes an object straight along its own motion; the palm pushes back on the
    # same line through a contact whose normal is tilted by t: the line of force is t off that normal.
    hand = pg.load_hand(str(BARRETT))
    q = np.array([0.0, 0.0, 0.0, 1.2])
    t = np.asarray(hand.link_transforms(q)["bh_f3_dist"])
    tip = t[:3, :3] @ np.array([0.02, 0.0, 0.0]) + t[:3, 3]
    v = _point_motion(hand, q, "bh_f3_dist", tip, 3)
    u = v / np.linalg.norm(v)
    palm = tip + 0.04 * u
    axis = np.cross(u, [0.0, 0.0, 1.0])
    axis /= np.linalg.norm(axis)
    b = math.radians(tilt_deg)
    normals = np.array([-u, _tilted(u, axis, b)])          # outward: against each push
    wrist = np.eye(4)
    wrist[:3, 3] = [0.01, 0.02, -0.03]
    pts = np.array([tip, palm]) + wrist[:3, 3]
    mu = pg.closing_friction(hand, wrist, q, pts, normals, ["bh_f3_dist", "bh_palm"], pts.mean(0), edges=64,
                             tolerance=1e-4)
    assert mu == pytest.approx(math.tan(b), rel=2e-3, abs=2e-4)
    # without the palm, finger 3 pushes the object away: no friction balances it
    assert pg.closing_friction(hand, wrist, q, pts[:1], normals[:1], ["bh_f3_dist"], pts.mean(0)) == math.inf
    # only the palm touches: no closing DOF pushes anything
    assert math.isnan(pg.closing_friction(hand, wrist, q, pts[1:], normals[1:], ["bh_palm"], pts.mean(0)))


def test_planned_barrett_grasps_get_a_finite_or_infinite_friction_and_bad_input_is_refused(barrett_mug):
    planner, result = barrett_mug
    hand = planner.hand
    seen = 0
    for g in result.grasps:
        mu = pg.closing_friction(hand, g.wrist_pose, g.dofs, g.contact_points, g.contact_normals, g.contact_links,
                                 planner.center)
        assert math.isnan(mu) or mu == math.inf or 0.0 <= mu <= 2.0
        seen += not math.isnan(mu)
    assert seen >= 1
    g = result.grasps[0]
    args = (hand, g.wrist_pose, g.dofs, g.contact_points, g.contact_normals, g.contact_links, planner.center)
    with pytest.raises(ValueError, match="links"):
        pg.closing_friction(*args[:5], ["no_such_link"] * len(g.contact_links), planner.center)
    with pytest.raises(ValueError, match="points"):
        pg.closing_friction(hand, g.wrist_pose, g.dofs, np.full((len(g.contact_links), 3), np.nan),
                            g.contact_normals, g.contact_links, planner.center)
    with pytest.raises(ValueError, match="wrist_pose"):
        pg.closing_friction(hand, np.eye(3), *args[2:])
    with pytest.raises(ValueError, match="mu_max"):
        pg.closing_friction(*args, mu_max=-1.0)
    with pytest.raises(ValueError):
        pg.closing_friction(hand, g.wrist_pose, np.full(4, 9.0), *args[3:])   # beyond the DOF limits
