// The fiber in 3D (three.js): the fiber along x (root → tip), the incident ray, the specular
// cone θ_r = −θ_i, and the scattering lobe as a surface whose radius in each direction ω_r is
// f_s(ω_i, ω_r) on the map's scale (log: decades above the floor; linear: f_s/max), coloured
// like the map. For a surface model: a disc with the hemisphere lobe over it.

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { position, scaleFor, viridis } from './colormap';
import type { MapAnswer } from './types';

/** Fiber-frame direction (x = tangent) at inclination θ and azimuth φ, degrees. */
export function fiberDirection(thetaDeg: number, phiDeg: number): [number, number, number] {
  const t = (thetaDeg * Math.PI) / 180;
  const p = (phiDeg * Math.PI) / 180;
  return [Math.sin(t), Math.cos(t) * Math.cos(p), Math.cos(t) * Math.sin(p)];
}

/** Surface direction (z = normal) at θ from the normal and azimuth φ, degrees. */
export function surfaceDirection(thetaDeg: number, phiDeg: number): [number, number, number] {
  const t = (thetaDeg * Math.PI) / 180;
  const p = (phiDeg * Math.PI) / 180;
  return [Math.sin(t) * Math.cos(p), Math.sin(t) * Math.sin(p), Math.cos(t)];
}

export class FiberView {
  private renderer: THREE.WebGLRenderer;
  private scene = new THREE.Scene();
  private camera: THREE.PerspectiveCamera;
  private controls: OrbitControls;
  private dynamic = new THREE.Group();

  constructor(private host: HTMLElement) {
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    const w = host.clientWidth || 420;
    const h = host.clientHeight || 320;
    this.renderer.setSize(w, h);
    this.renderer.setClearColor(0xf4f4f6);
    host.appendChild(this.renderer.domElement);
    this.camera = new THREE.PerspectiveCamera(40, w / h, 0.01, 100);
    this.camera.position.set(2.2, 1.6, 3.2);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.draw());
    this.scene.add(new THREE.AmbientLight(0xffffff, 1.2));
    const key = new THREE.DirectionalLight(0xffffff, 1.5);
    key.position.set(3, 4, 2);
    this.scene.add(key);
    this.scene.add(this.dynamic);
    const axes = new THREE.AxesHelper(0.4);
    this.scene.add(axes);
    new ResizeObserver(() => this.resize()).observe(host);
  }

  private resize(): void {
    const w = this.host.clientWidth;
    const h = this.host.clientHeight;
    if (w === 0 || h === 0) return;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.draw();
  }

  draw(): void {
    this.renderer.render(this.scene, this.camera);
  }

  /** A PNG of the view. */
  png(): string {
    this.draw();
    return this.renderer.domElement.toDataURL('image/png');
  }

  private clear(): void {
    for (const child of [...this.dynamic.children]) {
      this.dynamic.remove(child);
      child.traverse((o) => {
        const mesh = o as THREE.Mesh;
        mesh.geometry?.dispose?.();
        const m = mesh.material as THREE.Material | THREE.Material[] | undefined;
        if (Array.isArray(m)) m.forEach((x) => x.dispose());
        else m?.dispose?.();
      });
    }
  }

  /** Shows the fiber (or the surface), the light and the lobe of `map`. */
  update(map: MapAnswer | null, thetaI: number, phiI: number, log: boolean, decades: number): void {
    this.clear();
    const surface = map?.kind === 'surface';
    const dir = (t: number, p: number) => new THREE.Vector3(...(surface ? surfaceDirection(t, p) : fiberDirection(t, p)));
    if (surface) {
      const disc = new THREE.Mesh(new THREE.CircleGeometry(1.2, 64), new THREE.MeshStandardMaterial({ color: 0xb0a890, side: THREE.DoubleSide, transparent: true, opacity: 0.6 }));
      this.dynamic.add(disc);
      this.camera.up.set(0, 0, 1);
    } else {
      const fiber = new THREE.Mesh(new THREE.CylinderGeometry(0.07, 0.07, 3.2, 32, 1, true), new THREE.MeshStandardMaterial({ color: 0x8a5a2b, roughness: 0.5, transparent: true, opacity: 0.85 }));
      fiber.rotation.z = -Math.PI / 2; // cylinder's axis (y) onto x
      this.dynamic.add(fiber);
      this.camera.up.set(0, 1, 0);
      // Specular cone θ_r = −θ_i around the axis.
      const t = (thetaI * Math.PI) / 180;
      const cone = new THREE.Mesh(
        new THREE.ConeGeometry(1.3 * Math.cos(t), Math.abs(1.3 * Math.sin(t)) || 1e-3, 64, 1, true),
        new THREE.MeshBasicMaterial({ color: 0xd62728, transparent: true, opacity: 0.18, side: THREE.DoubleSide, depthWrite: false }),
      );
      // Apex at the origin, opening toward −x·sign(θ_i) (θ_r = −θ_i).
      cone.rotation.z = thetaI >= 0 ? -Math.PI / 2 : Math.PI / 2;
      cone.position.x = -0.65 * Math.sin(t);
      this.dynamic.add(cone);
    }
    // Incident ray: from the light toward the origin.
    const wi = dir(thetaI, phiI);
    const arrow = new THREE.ArrowHelper(wi.clone().negate(), wi.clone().multiplyScalar(1.8), 1.6, 0xffb000, 0.18, 0.09);
    this.dynamic.add(arrow);
    if (map && !map.delta && (map.max ?? 0) > 0) this.dynamic.add(this.lobe(map, phiI, log, decades, dir));
    this.draw();
  }

  private lobe(map: MapAnswer, phiI: number, log: boolean, decades: number, dir: (t: number, p: number) => THREE.Vector3): THREE.Mesh {
    const scale = scaleFor(map.max ?? 1, log, decades);
    const { rows, cols } = map;
    const positions: number[] = [];
    const colors: number[] = [];
    const surface = map.kind === 'surface';
    const at = (r: number, c: number) => map.values[Math.min(rows - 1, Math.max(0, r)) * cols + ((c + cols) % cols)];
    for (let r = 0; r <= rows; r++) {
      for (let c = 0; c <= cols; c++) {
        // Corner value: mean of the four cells around it.
        const v = (at(r - 1, c - 1) + at(r - 1, c) + at(r, c - 1) + at(r, c)) / 4;
        const s = position(scale, v);
        const theta = map.theta[0] + (r / rows) * (map.theta[1] - map.theta[0]);
        const phi = map.phi[0] + (c / cols) * (map.phi[1] - map.phi[0]) + (surface ? 0 : phiI);
        const p = dir(theta, phi).multiplyScalar(1.4 * s);
        positions.push(p.x, p.y, p.z);
        const rgb = viridis(s);
        colors.push(rgb[0] / 255, rgb[1] / 255, rgb[2] / 255);
      }
    }
    const index: number[] = [];
    for (let r = 0; r < rows; r++) {
      for (let c = 0; c < cols; c++) {
        const a = r * (cols + 1) + c;
        const b = a + cols + 1;
        index.push(a, b, a + 1, a + 1, b, b + 1);
      }
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
    g.setAttribute('color', new THREE.Float32BufferAttribute(colors, 3));
    g.setIndex(index);
    g.computeVertexNormals();
    return new THREE.Mesh(g, new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide, transparent: true, opacity: 0.9 }));
  }
}
