// A small robodyn client in TypeScript, written only against the types that openapi-typescript
// generates (default settings) from the service's /openapi.json: it must compile with no cast
// and no `any` (tests/typescript/test_typescript_client.py checks both, then runs it against a
// real server).
import type { components, operations } from "./generated/robodyn";

type Schemas = components["schemas"];
export type Problem = Schemas["Problem"];
type RobotList = operations["listRobots"]["responses"][200]["content"]["application/json"];
type RobotInfo = operations["robotInfo"]["responses"][200]["content"]["application/json"];
type MassMatrixRequest =
  operations["massMatrix"]["requestBody"]["content"]["application/json"];
type MassMatrixAnswer =
  operations["massMatrix"]["responses"][200]["content"]["application/json"];
type UploadRequest = operations["uploadRobot"]["requestBody"]["content"]["application/json"];
type Matrix = MassMatrixAnswer["mass_matrix"];

/** An answer: the typed body of a success, or the problem of an error. */
type Answer<T> = { ok: true; status: number; body: T } | { ok: false; status: number; problem: Problem };

async function call<T>(base: string, method: string, path: string, body?: object): Promise<Answer<T>> {
  const init: RequestInit = { method, headers: { accept: "application/json" } };
  if (body !== undefined) {
    init.headers = { "content-type": "application/json", accept: "application/json" };
    init.body = JSON.stringify(body);
  }
  const response = await fetch(base + path, init);
  if (response.ok) {
    const ok: T = await response.json();
    return { ok: true, status: response.status, body: ok };
  }
  const problem: Problem = await response.json();
  return { ok: false, status: response.status, problem };
}

/** One state's M (nv × nv) or a batch (N × nv × nv): the answer's shape follows q's. */
function isSingle(m: Matrix): m is number[][] {
  return m.length > 0 && m[0].length > 0 && typeof m[0][0] === "number";
}

export interface Summary {
  robots: string[];
  nq: number;
  jointNames: string[];
  single: number[][];
  batchShape: number[];
  uploadStatus: number;
  uploadId: string;
  problemCode: Problem["code"];
  problemDetail: string;
  problemLocations: string[];
  robotNotFound: boolean;
}

function fail(what: string, answer: Answer<unknown>): never {
  const why = answer.ok ? `status ${answer.status}` : `${answer.problem.code}: ${answer.problem.detail}`;
  throw new Error(`${what} failed (${why})`);
}

export async function run(base: string, urdf: string): Promise<Summary> {
  const list = await call<RobotList>(base, "GET", "/v1/robots");
  if (!list.ok) fail("listing the robots", list);
  const robots = list.body.robots.map((r) => r.id);

  const info = await call<RobotInfo>(base, "GET", "/v1/robots/ur5");
  if (!info.ok) fail("robot info", info);
  const nq: number = info.body.nq;
  const jointNames = info.body.joints.map((j) => j.name);

  // Fields with defaults (joint_names, ...) need not be given.
  const single: MassMatrixRequest = { q: [0, -1.57, 1.57, 0, 0, 0] };
  const one = await call<MassMatrixAnswer>(base, "POST", "/v1/robots/ur5/mass-matrix", single);
  if (!one.ok) fail("mass matrix", one);
  const m = one.body.mass_matrix;
  if (!isSingle(m)) throw new Error("one state gave a batch");

  const batch: MassMatrixRequest = { q: [[0, 0, 0, 0, 0, 0], [0, -1.57, 1.57, 0, 0, 0]] };
  const many = await call<MassMatrixAnswer>(base, "POST", "/v1/robots/ur5/mass-matrix", batch);
  if (!many.ok) fail("mass matrix batch", many);
  const mb = many.body.mass_matrix;
  if (isSingle(mb)) throw new Error("a batch gave one state");
  const batchShape = [mb.length, mb[0].length, mb[0][0].length];

  // gravity, inertia_check, mjcf, locked_joints, ... have defaults: only the text is needed.
  const upload: UploadRequest = { urdf, root_joint: "fixed", name: "my arm" };
  const stored = await call<RobotInfo>(base, "POST", "/v1/robots", upload);
  if (!stored.ok) fail("upload", stored);

  const wrong: MassMatrixRequest = { q: [0, 0, 0, 0, 0] };
  const refused = await call<MassMatrixAnswer>(base, "POST", "/v1/robots/ur5/mass-matrix", wrong);
  if (refused.ok) throw new Error("a q of 5 entries was accepted for the UR5");
  const typo = await call<MassMatrixAnswer>(base, "POST", "/v1/robots/ur5/mass-matrix", { q: "0" });
  if (typo.ok) throw new Error("a string q was accepted");
  const unknown = await call<RobotInfo>(base, "GET", "/v1/robots/ur6");
  const robotNotFound = !unknown.ok && unknown.problem.code === "robot_not_found";

  return {
    robots,
    nq,
    jointNames,
    single: m,
    batchShape,
    uploadStatus: stored.status,
    uploadId: stored.body.id,
    problemCode: refused.problem.code,
    problemDetail: refused.problem.detail,
    problemLocations: (typo.ok ? [] : typo.problem.errors ?? []).map((e) => e.loc),
    robotNotFound,
  };
}
