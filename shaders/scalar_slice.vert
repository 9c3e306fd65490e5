// Slice plane: passes the plane's (u, v) texture coordinate to the fragment shader.
varying vec2 vUv;
void main() {
  vUv = uv;
  gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);
}
