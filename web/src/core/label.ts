// A text label that faces the camera and draws over everything: a sprite of a canvas.
import * as THREE from "three";

/** `text` in `color`, `height` metres tall (the sprite is 4 heights wide, the text centred). */
export function textLabel(text: string, color: number, height = 0.1): THREE.Sprite {
  const c = document.createElement("canvas");
  c.width = 256;
  c.height = 64;
  const ctx = c.getContext("2d")!;
  ctx.font = "bold 40px system-ui, sans-serif";
  ctx.fillStyle = `#${color.toString(16).padStart(6, "0")}`;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillText(text, 128, 32);
  const s = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(c), depthTest: false, transparent: true }));
  s.scale.set(4 * height, height, 1);
  s.renderOrder = 12;
  s.userData.text = text;
  return s;
}
