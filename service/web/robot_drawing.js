// robodyn explorer, the robot drawn in 3-D with three.js (vendored in vendor/three/, see its
// README), z up as in robotics. Each link's visuals hang in a group placed at that link's body
// frame; the service gives the frames' world placements (POST frame-placements) and the visuals
// (GET visuals), and the meshes come from GET assets/{path}, each fetched once (cached), through
// http.js like every request of the page.
// A robot without visuals is drawn as a stick figure: joint origins joined by segments.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { STLLoader } from "three/addons/loaders/STLLoader.js";
import { ColladaLoader } from "three/addons/loaders/ColladaLoader.js";
import { OBJLoader } from "three/addons/loaders/OBJLoader.js";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { request } from "./http.js";

const BACKGROUND = 0xf7f8fa;
const DEFAULT_COLOUR = [0.72, 0.74, 0.78, 1];
// Colours are given as CSS gives them (sRGB, 0–1); three.js works in linear light.
const srgb = (r, g, b) => new THREE.Color().setRGB(r, g, b, THREE.SRGBColorSpace);
const NEUTRAL = srgb(0.8, 0.8, 0.8); // links without a value in colour-by mode

// url → Promise of a template Object3D; templates are cloned (sharing geometry) per visual.
const meshCache = new Map();

function parseMesh(url, buffer) {
  const ext = url.split("?")[0].split(".").pop().toLowerCase();
  if (ext === "stl") {
    const geometry = new STLLoader().parse(buffer);
    geometry.computeVertexNormals();
    return new THREE.Mesh(geometry, null); // material per visual (the description's colour)
  }
  const text = () => new TextDecoder().decode(buffer);
  if (ext === "dae") {
    const base = url.slice(0, url.lastIndexOf("/") + 1);
    const scene = new ColladaLoader().parse(text(), base).scene;
    // robodyn's world is z up like the description: undo the loader's Z_UP → Y_UP turn.
    scene.rotation.set(0, 0, 0);
    scene.updateMatrix();
    return scene;
  }
  if (ext === "obj") return new OBJLoader().parse(text());
  if (ext === "glb" || ext === "gltf") {
    return new Promise((resolve, reject) => {
      new GLTFLoader().parse(buffer, url.slice(0, url.lastIndexOf("/") + 1),
                             (gltf) => resolve(gltf.scene), reject);
    });
  }
  return null; // a format the page cannot draw
}

function loadMesh(url) {
  if (!meshCache.has(url)) {
    meshCache.set(url, request(url).then((res) => {
      if (!res.ok) throw new Error(`${res.status} for ${url}`);
      return res.arrayBuffer();
    }).then((buffer) => parseMesh(url, buffer)).then((template) => {
      // the template's geometries and materials are shared by its clones: never disposed
      if (template) {
        template.traverse((o) => {
          if (o.geometry) o.userData.cachedGeometry = true;
          for (const m of [o.material].flat()) if (m) m.userData.cached = true;
        });
      }
      return template;
    }).catch((err) => {
      meshCache.delete(url); // a failed fetch is tried again when the robot is chosen again
      throw err;
    }));
  }
  return meshCache.get(url);
}

function primitive(geometry) {
  switch (geometry.type) {
    case "box": return new THREE.BoxGeometry(...geometry.size);
    case "sphere": return new THREE.SphereGeometry(geometry.radius, 24, 16);
    case "cylinder": // three's cylinders run along y; the description's along z
      return new THREE.CylinderGeometry(geometry.radius, geometry.radius, geometry.length, 24)
        .rotateX(Math.PI / 2);
    case "capsule":
      return new THREE.CapsuleGeometry(geometry.radius, geometry.length, 8, 24)
        .rotateX(Math.PI / 2);
    default: return null;
  }
}

const meshCount = (visuals) => visuals.filter((v) => v.geometry.type === "mesh").length;

const placementMatrix = (R, p) => new THREE.Matrix4().set(
  R[0][0], R[0][1], R[0][2], p[0], R[1][0], R[1][1], R[1][2], p[1],
  R[2][0], R[2][1], R[2][2], p[2], 0, 0, 0, 1);

// A letter drawn on a sprite (it always faces the camera), `size` m high, seen through the links.
function letterSprite(text, colour, size) {
  const canvas = document.createElement("canvas");
  canvas.width = canvas.height = 64;
  const ctx = canvas.getContext("2d");
  ctx.font = "bold 52px sans-serif";
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillStyle = colour;
  ctx.fillText(text, 32, 34);
  const map = new THREE.CanvasTexture(canvas);
  map.colorSpace = THREE.SRGBColorSpace;
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map, depthTest: false }));
  sprite.scale.set(size, size, 1);
  sprite.renderOrder = 12;
  return sprite;
}

function material(rgba) {
  const [r, g, b, a] = rgba || DEFAULT_COLOUR;
  return new THREE.MeshStandardMaterial({ color: srgb(r, g, b), roughness: 0.6,
                                          metalness: 0.1, transparent: a < 1, opacity: a });
}

export class RobotDrawing {
  constructor(container, { onProgress = () => {} } = {}) {
    this.container = container;
    this.onProgress = onProgress;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(2, window.devicePixelRatio || 1));
    this.renderer.setClearColor(BACKGROUND);
    container.append(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.01, 200);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(1.6, -1.6, 1.2);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8a8a, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(1, -1, 2);
    this.camera.add(sun); // a light from the viewer's side: every face that is seen is lit
    this.scene.add(this.camera);
    const grid = new THREE.GridHelper(4, 40, 0x9aa3ad, 0xd5d9de); // 10 cm squares
    grid.rotation.x = Math.PI / 2; // into the x-y plane
    this.scene.add(grid, new THREE.AxesHelper(0.3)); // world axes: x red, y green, z blue
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => { this.moved = true; this.requestRender(); });
    this.com = new THREE.Mesh(new THREE.SphereGeometry(0.025, 20, 12),
                              new THREE.MeshBasicMaterial({ color: 0xd81b60, depthTest: false }));
    this.com.renderOrder = 10; // seen through the links
    this.com.visible = false;
    this.scene.add(this.com);
    this.root = new THREE.Group();
    this.scene.add(this.root);
    this.frames = new Map(); // body frame name → its Group
    this.triads = false;
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const w = this.container.clientWidth || 400, h = this.container.clientHeight || 300;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender() {
    if (this.pending) return;
    this.pending = requestAnimationFrame(() => {
      this.pending = 0;
      this.renderer.render(this.scene, this.camera);
      this.container.dataset.rendered = String(Number(this.container.dataset.rendered || 0) + 1);
    });
  }

  /** A new robot: `info` (GET robots/{id}), its `visuals`, the URL of an asset path, and
   * (for a stick figure) the `bodies` of GET robots/{id}/inertias. */
  setRobot(info, visuals, assetUrl, inertias = []) {
    this.dispose();
    this.frames.clear();
    this.info = info;
    this.fitted = false; // the camera was aimed at this robot
    this.placed = false; // its frames have been placed
    this.meshesDone = false;
    this.moved = false;
    this.sticks = null;
    const mine = this.generation = (this.generation || 0) + 1;
    const drawable = visuals.filter((v) => v.geometry.type !== "mesh" ||
      /\.(stl|dae|obj|glb|gltf)$/i.test(v.geometry.asset));
    this.stick = drawable.length === 0;
    let drawn = drawable.length - meshCount(drawable); // primitives; meshes once loaded
    for (const f of info.frames.filter((x) => x.type === "body")) this.group(f.name);
    const meshes = drawable.filter((v) => v.geometry.type === "mesh");
    // files the upload's answer already said it does not have (warnings "missing_mesh"): not
    // fetched, reported as missing
    const missing = new Set((info.warnings || []).filter((w) => w.code === "missing_mesh")
      .map((w) => w.file));
    let done = 0;
    const failed = this.failed = []; // the mesh file of each mesh visual not drawn
    const report = () => this.onProgress(done, meshes.length, failed);
    this.meshesDone = meshes.length === 0;
    report();
    for (const visual of drawable) {
      const holder = new THREE.Group();
      holder.matrixAutoUpdate = false;
      holder.matrix.copy(placementMatrix(visual.placement.rotation,
                                         visual.placement.translation));
      this.group(visual.frame).add(holder);
      if (visual.geometry.type !== "mesh") {
        const mesh = new THREE.Mesh(primitive(visual.geometry), material(visual.color));
        mesh.userData.own = mesh.material;
        holder.add(mesh);
        continue;
      }
      const { asset, scale } = visual.geometry;
      const loading = missing.has(asset)
        ? Promise.reject(new Error("not among the upload's files"))
        : Promise.resolve(loadMesh(assetUrl(asset)));
      loading.then(async (template) => {
        template = await template;
        if (mine === this.generation && !template) throw new Error("not drawable");
        if (mine !== this.generation || !template) return;
        const object = template.clone();
        object.scale.multiply(new THREE.Vector3(...scale));
        object.traverse((o) => {
          if (!o.isMesh) return;
          // the description's colour wins; a mesh without one keeps its own materials
          if (!o.material || visual.color) o.material = material(visual.color);
          o.userData.own = o.material;
        });
        holder.add(object);
        drawn += 1;
        this.applyColours();
      }).catch((err) => {
        if (mine === this.generation) failed.push(asset);
        console.warn(`mesh ${asset} not drawn: ${err.message}`);
      })
        .finally(() => {
          if (mine !== this.generation) return;
          done += 1;
          report();
          if (done === meshes.length) {
            this.meshesDone = true;
            // not one mesh could be had (an upload without its mesh files): a stick figure
            if (drawn === 0) this.becomeStickFigure(inertias);
            if (this.placed) this.fit(); // aim at the whole robot, meshes included
          }
          this.requestRender();
        });
    }
    if (this.stick) this.buildStickFigure(inertias);
    this.container.dataset.mode = this.stick ? "stick" : "visuals";
    this.lastPlacements = null;
    this.container.dataset.robot = info.id;
    this.setTriads(this.triads);
    this.requestRender();
  }

  dispose() {
    // Free the GPU buffers of the robot shown, except the cached meshes' geometries (shared
    // by every clone of a mesh, and kept for when the robot is chosen again).
    this.root.traverse((o) => {
      if (o.geometry && !o.userData.cachedGeometry) o.geometry.dispose();
      for (const m of [o.material, o.userData.own, o.userData.tint].flat()) {
        if (m && m.dispose && !m.userData.cached) m.dispose();
      }
    });
    this.root.clear();
  }

  group(name) {
    let g = this.frames.get(name);
    if (!g) {
      g = new THREE.Group();
      g.matrixAutoUpdate = false;
      g.visible = false; // until placed
      this.frames.set(name, g);
      this.root.add(g);
    }
    return g;
  }

  becomeStickFigure(inertias) {
    this.stick = true;
    this.buildStickFigure(inertias);
    this.container.dataset.mode = "stick";
    if (this.lastPlacements) this.setPlacements(...this.lastPlacements);
    this.onProgress(0, 0, this.failed || []);
  }

  buildStickFigure(inertias) {
    // One segment from each joint's origin to its parent joint's origin (the world origin for
    // a root joint), and to every other body frame of the joint (fixed links, tool frames);
    // each body's centre of mass as a small ball joined to its joint (the last link shows).
    const joints = this.info.joints;
    const bodies = this.info.frames.filter((f) => f.type === "body");
    const origin = new Map(); // joint name → name of its first body frame (at the joint)
    for (const f of bodies) if (!origin.has(f.parent_joint)) origin.set(f.parent_joint, f.name);
    const pairs = [];
    for (const j of joints) {
      if (origin.has(j.name)) pairs.push([origin.get(j.parent) || null, origin.get(j.name)]);
    }
    for (const f of bodies) {
      const first = origin.get(f.parent_joint);
      if (first !== f.name && first) pairs.push([first, f.name]);
    }
    this.sticks = pairs;
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.Float32BufferAttribute(pairs.length * 6, 3));
    this.stickLines = new THREE.LineSegments(
      geometry, new THREE.LineBasicMaterial({ color: 0x1b1b1b }));
    this.stickLines.frustumCulled = false;
    const ball = new THREE.SphereGeometry(0.02, 16, 10);
    for (const frame of origin.values()) {
      const m = new THREE.Mesh(ball, material([0.05, 0.36, 0.68, 1]));
      m.userData.own = m.material;
      this.group(frame).add(m);
    }
    this.root.add(this.stickLines);
    const comBall = new THREE.SphereGeometry(0.012, 12, 8);
    for (const b of inertias) {
      const frame = origin.get(b.joint);
      if (!frame || !(b.mass > 0)) continue;
      const c = new THREE.Vector3(...b.center_of_mass);
      const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(
        [new THREE.Vector3(), c]), new THREE.LineBasicMaterial({ color: 0x6b6b6b }));
      const ball = new THREE.Mesh(comBall, material([0.9, 0.55, 0.1, 1]));
      ball.position.copy(c);
      ball.userData.own = ball.material;
      this.group(frame).add(line, ball); // both move with the joint's frame
    }
  }

  /** World placements of frames (names, F×3 positions, F×3×3 rotations) for configuration q. */
  setPlacements(frames, positions, rotations, q) {
    const started = performance.now();
    this.lastPlacements = [frames, positions, rotations, q];
    const where = new Map();
    frames.forEach((name, k) => {
      where.set(name, positions[k]);
      const g = this.frames.get(name);
      if (!g) return;
      g.matrix.copy(placementMatrix(rotations[k], positions[k]));
      g.matrixWorldNeedsUpdate = true;
      g.visible = true;
    });
    if (this.stick && this.sticks) {
      const attr = this.stickLines.geometry.getAttribute("position");
      this.sticks.forEach(([a, b], k) => {
        const pa = (a && where.get(a)) || [0, 0, 0], pb = where.get(b) || pa;
        attr.setXYZ(2 * k, ...pa);
        attr.setXYZ(2 * k + 1, ...pb);
      });
      attr.needsUpdate = true;
      this.stickLines.geometry.computeBoundingBox();
    }
    this.container.dataset.q = JSON.stringify(q);
    this.container.dataset.placeMs = (performance.now() - started).toFixed(3);
    this.placed = true;
    // aim at what is drawn: a stick figure or loaded meshes, else the frames' origins
    if (!this.fitted) this.fit(this.meshesDone ? null : positions);
    this.requestRender();
  }

  setCenterOfMass(p) {
    this.comAt = p || null;
    if (p) this.com.position.set(...p);
    this.com.visible = !!p && this.showCom !== false;
    this.requestRender();
  }

  setShowCom(on) {
    this.showCom = on;
    this.com.visible = on && !!this.comAt;
    this.requestRender();
  }

  setTriads(on) {
    this.triads = on;
    for (const g of this.frames.values()) {
      let axes = g.children.find((c) => c.userData.triad);
      if (on && !axes) {
        axes = new THREE.AxesHelper(0.08);
        axes.userData.triad = true;
        g.add(axes);
      }
      if (axes) axes.visible = on;
    }
    this.requestRender();
  }

  /** One frame's axes at its world placement — `mark` {name, position (m), rotation (3×3, its
   * axes as columns), point (3 numbers in the frame's coordinates, m, or null)} — drawn
   * x red, y green, z blue (15 cm, labelled) and seen through the links, with `point` as a
   * purple ball; null hides them. The payload view marks the payload's frame and its centre
   * of mass with it. */
  setFrameMark(mark) {
    if (!this.frameMark) this.frameMark = this.buildFrameMark();
    const g = this.frameMark;
    g.visible = !!mark;
    if (mark) {
      g.matrix.copy(placementMatrix(mark.rotation, mark.position));
      g.matrixWorldNeedsUpdate = true;
      g.userData.point.visible = !!mark.point;
      if (mark.point) g.userData.point.position.set(...mark.point);
      g.userData.frame = mark.name;
      this.container.dataset.markedFrame = mark.name;
    } else {
      delete this.container.dataset.markedFrame;
    }
    this.setEllipsoids(mark ? mark.ellipsoids || [] : []);
    this.requestRender();
  }

  /** Ellipsoids in the marked frame's coordinates, each {center [3] m, axes 3×3 (columns:
   * the semi-axes' directions), radii [3] m, colour "#rrggbb"}: wireframes drawn over the
   * robot, replaced on every call. */
  setEllipsoids(ellipsoids) {
    const g = this.frameMark;
    if (!g) return;
    if (g.userData.ellipsoids) {
      g.remove(g.userData.ellipsoids);
      g.userData.ellipsoids.traverse((o) => { if (o.geometry) o.geometry.dispose(); });
    }
    const group = new THREE.Group();
    for (const e of ellipsoids) {
      const mesh = new THREE.Mesh(
        new THREE.SphereGeometry(1, 24, 16),
        new THREE.MeshBasicMaterial({ color: e.colour, wireframe: true, transparent: true,
                                      opacity: 0.7, depthTest: false }));
      mesh.renderOrder = 12;
      mesh.matrixAutoUpdate = false;
      const radii = e.radii.map((r) => Math.max(r, 1e-4)); // a flat axis: drawn thin
      mesh.matrix.copy(placementMatrix(e.axes, e.center))
        .multiply(new THREE.Matrix4().makeScale(...radii));
      group.add(mesh);
    }
    g.add(group);
    g.userData.ellipsoids = group;
    this.container.dataset.ellipsoids = String(ellipsoids.length);
  }

  buildFrameMark() {
    const LENGTH = 0.15; // m
    const g = new THREE.Group();
    g.matrixAutoUpdate = false;
    const axes = new THREE.AxesHelper(LENGTH).setColors(0xff0000, 0x00b000, 0x0000ff);
    axes.material.depthTest = false;
    axes.renderOrder = 11;
    g.add(axes);
    g.userData.axes = axes;
    ["#d00000", "#008000", "#0000d0"].forEach((colour, k) => { // "x", "y", "z" beyond each end
      const letter = letterSprite("xyz"[k], colour, 0.045);
      letter.position.setComponent(k, LENGTH + 0.03);
      g.add(letter);
    });
    const point = new THREE.Mesh(
      new THREE.SphereGeometry(0.015, 16, 10),
      new THREE.MeshBasicMaterial({ color: 0x6a1b9a, depthTest: false }));
    point.renderOrder = 11;
    g.add(point);
    g.userData.point = point;
    this.scene.add(g); // beside the robot's links (not under `root`: kept across robots)
    return g;
  }

  /** Colour each link by a value: `colourOf(frameName)` gives a THREE-free [r, g, b] in 0–1
   * or null (neutral grey); no function restores the description's own colours. */
  setLinkColours(colourOf) {
    this.colourOf = colourOf;
    this.applyColours();
    this.requestRender();
  }

  applyColours() {
    const by = this.colourOf;
    for (const [name, g] of this.frames) {
      let tint = null;
      if (by) {
        const rgb = by(name);
        tint = g.userData.tint ||= new THREE.MeshStandardMaterial({ roughness: 0.7 });
        tint.color.copy(rgb ? srgb(...rgb) : NEUTRAL);
      }
      g.traverse((o) => {
        if (o.isMesh && o.userData.own) o.material = tint || o.userData.own;
      });
    }
  }

  fit(positions) {
    // Frame the robot: its meshes' bounding box, or (before they load) its frames' origins.
    if (this.moved) return; // the user has placed the camera: leave it
    const box = new THREE.Box3();
    if (positions) for (const p of positions) box.expandByPoint(new THREE.Vector3(...p));
    else box.setFromObject(this.root);
    if (box.isEmpty()) return;
    const centre = box.getCenter(new THREE.Vector3());
    const radius = Math.max(0.25, box.getSize(new THREE.Vector3()).length() / 2 + 0.1);
    const distance = radius / Math.sin((this.camera.fov * Math.PI) / 360);
    const dir = new THREE.Vector3(0.75, -1, 0.45).normalize(); // front right, a little above
    this.camera.position.copy(centre).addScaledVector(dir, distance);
    this.controls.target.copy(centre);
    this.controls.update();
    this.moved = false; // update() fired "change": this was not the user
    this.fitted = true;
    this.requestRender();
  }
}
