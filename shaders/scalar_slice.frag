// Slice plane coloured by a scalar field (a float texture sampled by the server on a grid), with
// contour lines every `spacing` drawn at constant screen width (fwidth), the zero level bold.
// Samples that are NaN (inside the object, or undefined) are drawn as a flat grey.
precision highp float;
uniform sampler2D field;
uniform vec2 range;      // value mapped to the ends of the colour map
uniform float spacing;   // contour spacing (same units as the field); <= 0: no contours
uniform float opacity;
uniform int diverging;   // 1: blue-white-red around 0; 0: a viridis-like sequential map
varying vec2 vUv;

vec3 sequential(float t) {
  // Polynomial fit of viridis (after mattz's approximation).
  const vec3 c0 = vec3(0.2777, 0.0054, 0.3341);
  const vec3 c1 = vec3(0.1051, 1.4046, 1.3846);
  const vec3 c2 = vec3(-0.3309, 0.2148, 0.0951);
  const vec3 c3 = vec3(-4.6342, -5.7991, -19.3324);
  const vec3 c4 = vec3(6.2283, 14.1799, 56.6906);
  const vec3 c5 = vec3(4.7764, -13.7451, -65.3530);
  const vec3 c6 = vec3(-5.4355, 4.6459, 26.3124);
  return c0 + t * (c1 + t * (c2 + t * (c3 + t * (c4 + t * (c5 + t * c6)))));
}

vec3 divergingMap(float t) { // t in [0, 1], 0.5 = white
  vec3 blue = vec3(0.23, 0.30, 0.75), white = vec3(0.95), red = vec3(0.71, 0.02, 0.15);
  return t < 0.5 ? mix(blue, white, t * 2.0) : mix(white, red, t * 2.0 - 1.0);
}

void main() {
  float f = texture2D(field, vUv).r;
  if (f != f) { gl_FragColor = vec4(0.35, 0.37, 0.40, opacity); return; } // NaN
  float t;
  if (diverging == 1) {
    float m = max(abs(range.x), abs(range.y));
    t = clamp(0.5 + 0.5 * f / max(m, 1e-12), 0.0, 1.0);
  } else {
    t = clamp((f - range.x) / max(range.y - range.x, 1e-12), 0.0, 1.0);
  }
  vec3 color = diverging == 1 ? divergingMap(t) : sequential(t);
  if (spacing > 0.0) {
    float x = f / spacing;
    float w = fwidth(x);
    float line = 1.0 - smoothstep(0.0, 1.5 * w, abs(fract(x + 0.5) - 0.5));
    color = mix(color, vec3(0.05), 0.6 * line);
    float zw = fwidth(f);
    float zero = 1.0 - smoothstep(0.0, 2.5 * zw, abs(f));
    color = mix(color, vec3(1.0, 1.0, 1.0), zero);
  }
  gl_FragColor = vec4(color, opacity);
}
