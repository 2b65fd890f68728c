// Joint coordinates of the explorer's sliders: one coordinate per velocity entry of a joint
// (angles as roll, pitch, yaw for a free flyer or a ball joint) and the map back to its q.

// The units of a coordinate of each kind: its position q, velocity v and force f.
export const UNITS = {
  angle: { q: "rad", v: "rad/s", f: "N·m" },
  length: { q: "m", v: "m/s", f: "N" },
  other: { q: "", v: "", f: "" },
};

export const LARGE = 1e3; // a limit beyond this counts as unbounded (Pinocchio's default is ±1.8e308)

export function rpyToQuat(roll, pitch, yaw) {
  // R = Rz(yaw) Ry(pitch) Rx(roll), as Pinocchio's rpy; q = [x, y, z, w], unit length.
  const [cr, sr] = [Math.cos(roll / 2), Math.sin(roll / 2)];
  const [cp, sp] = [Math.cos(pitch / 2), Math.sin(pitch / 2)];
  const [cy, sy] = [Math.cos(yaw / 2), Math.sin(yaw / 2)];
  const q = [sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
             cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy];
  const n = Math.hypot(...q);
  return q.map((x) => x / n);
}

export function quatToRpy([x, y, z, w]) {
  return [Math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)),
          Math.asin(Math.max(-1, Math.min(1, 2 * (w * y - z * x)))),
          Math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))];
}

export const finite = (x) => x !== null && Number.isFinite(x) && Math.abs(x) < LARGE;

function coord(suffix, vSuffix, kind, lo, hi, value, fallback) {
  // A slider range: the joint limits when both are finite, else the fallback, widened if
  // needed so that the starting value itself is kept exactly.
  let [min, max] = finite(lo) && finite(hi) && hi > lo ? [lo, hi] : fallback;
  min = Math.min(min, value);
  max = Math.max(max, value);
  return { suffix, vSuffix, kind, min, max, value };
}

export function jointCoordinates(j, q0, neutral) {
  // One coordinate per velocity entry (nv of them) and the map back to the joint's nq entries;
  // `neutral` is the robot's neutral_configuration (it shows a quaternion's order).
  const qj = q0.slice(j.idx_q, j.idx_q + j.nq);
  const lo = j.lower, hi = j.upper, PI = Math.PI;
  const ANGLE = [-PI, PI], LENGTH = [-1, 1];
  if (j.type === "free_flyer") {
    const [r, p, y] = quatToRpy(qj.slice(3, 7));
    return {
      coords: [coord("x", "vx", "length", lo[0], hi[0], qj[0], LENGTH),
               coord("y", "vy", "length", lo[1], hi[1], qj[1], LENGTH),
               coord("z", "vz", "length", lo[2], hi[2], qj[2], LENGTH),
               coord("roll", "ωx", "angle", null, null, r, ANGLE),
               coord("pitch", "ωy", "angle", null, null, p, [-PI / 2, PI / 2]),
               coord("yaw", "ωz", "angle", null, null, y, ANGLE)],
      toQ: (c) => [c[0], c[1], c[2], ...rpyToQuat(c[3], c[4], c[5])],
    };
  }
  if (j.type === "spherical") {
    // The identity in neutral_configuration shows the order: [1, 0, 0, 0] is w first (an MJCF
    // model, whose q is MuJoCo's qpos), [0, 0, 0, 1] w last (Pinocchio's).
    const wFirst = neutral[j.idx_q] === 1;
    const [r, p, y] = quatToRpy(wFirst ? [...qj.slice(1), qj[0]] : qj);
    return {
      coords: [coord("roll", "ωx", "angle", null, null, r, ANGLE),
               coord("pitch", "ωy", "angle", null, null, p, [-PI / 2, PI / 2]),
               coord("yaw", "ωz", "angle", null, null, y, ANGLE)],
      toQ: (c) => {
        const xyzw = rpyToQuat(c[0], c[1], c[2]);
        return wFirst ? [xyzw[3], ...xyzw.slice(0, 3)] : xyzw;
      },
    };
  }
  if (j.type === "planar") {
    return {
      coords: [coord("x", "vx", "length", lo[0], hi[0], qj[0], LENGTH),
               coord("y", "vy", "length", lo[1], hi[1], qj[1], LENGTH),
               coord("θ", "ω", "angle", null, null, Math.atan2(qj[3], qj[2]), ANGLE)],
      toQ: (c) => [c[0], c[1], Math.cos(c[2]), Math.sin(c[2])],
    };
  }
  if (j.type === "continuous") { // q = [cos θ, sin θ]
    return {
      coords: [coord("θ", "ω", "angle", null, null, Math.atan2(qj[1], qj[0]), ANGLE)],
      toQ: (c) => [Math.cos(c[0]), Math.sin(c[0])],
    };
  }
  if (j.nq === j.nv) { // revolute, prismatic, spherical_zyx, translation, ...
    const kind = ["revolute", "spherical_zyx"].includes(j.type) ? "angle"
      : ["prismatic", "translation"].includes(j.type) ? "length" : "other";
    const fallback = kind === "angle" ? ANGLE : LENGTH;
    const names = j.nv === 1 ? [""] : [...Array(j.nv).keys()].map(String);
    return {
      coords: names.map((s, k) => coord(s, s, kind, lo[k], hi[k], qj[k], fallback)),
      toQ: (c) => c,
    };
  }
  // An unknown joint whose q is not its v: held at the starting configuration.
  return {
    coords: [...Array(j.nv).keys()].map((k) => ({ suffix: String(k), vSuffix: String(k),
                                                  kind: "other", held: true })),
    toQ: () => qj,
  };
}
