// three.js geometry of GAP's round solids in distlab's convention: the axis along local z (three's
// cylinder and capsule have theirs along y). `radial`/`cap` set the tessellation.
import * as THREE from "three";

export function cylinderAlongZ(radius: number | undefined, height: number | undefined, radial: number): THREE.BufferGeometry {
  return new THREE.CylinderGeometry(radius, radius, height, radial).rotateX(Math.PI / 2);
}

/** `height` is the length of the core segment (between the two hemispheres' centres). */
export function capsuleAlongZ(radius: number | undefined, height: number | undefined, cap: number, radial: number): THREE.BufferGeometry {
  return new THREE.CapsuleGeometry(radius, height, cap, radial).rotateX(Math.PI / 2);
}
