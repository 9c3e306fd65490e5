// Slice plane coloured by a scalar field (a float texture sampled by the server on a grid), with
// contour lines every `spacing` drawn at constant screen width (fwidth), the zero level bold.
// Samples that are NaN (inside the object, or undefined) are drawn as a flat grey.
precision highp float;
uniform sampler2D field;
uniform vec2 range;      // value mapped to the ends of the colour map
uniform float spacing;   // contour spacing (same units as the field); <= 0: no contours
uniform float opacity;
uniform int centred;     // 1: a diverging map with 0 in its middle (each half of the range stretched)
uniform sampler2D colormap; // 256 sRGB colours (core/colormap.ts: the vertex colours and colour bars use the same)
varying vec2 vUv;

void main() {
  float f = texture2D(field, vUv).r;
  if (f != f) { gl_FragColor = vec4(0.35, 0.37, 0.40, opacity); return; } // NaN
  float t;
  if (centred == 1 && range.x < 0.0 && range.y > 0.0) t = f < 0.0 ? 0.5 - 0.5 * f / range.x : 0.5 + 0.5 * f / range.y;
  else t = (f - range.x) / max(range.y - range.x, 1e-12);
  // Texel centres: 256 colours span [0.5/256, 255.5/256].
  vec3 color = texture2D(colormap, vec2((clamp(t, 0.0, 1.0) * 255.0 + 0.5) / 256.0, 0.5)).rgb;
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
