// Meshes the browser tests make themselves: a closed box split into k × k squares per face (two
// triangles each, outward), its vertices shared, and its OBJ text.

/** The box of size [sx, sy, sz] centred at the origin: { vertices: [[x, y, z]], faces: [[i, j, k]] }
 *  (0-based). Faces come per box face in the order x−, x+, y−, y+, z−, z+, each k² squares of two
 *  triangles, row by row. */
export function gridBox(size, k) {
  const index = new Map(),
    vertices = [],
    faces = [];
  const vertex = (p) => {
    const key = p.join(",");
    if (!index.has(key)) {
      index.set(key, vertices.length);
      vertices.push(p);
    }
    return index.get(key);
  };
  for (const a of [0, 1, 2])
    for (const s of [-1, 1]) {
      const u = (a + 1) % 3,
        v = (a + 2) % 3; // e_u × e_v = e_a
      const corner = (i, j) => {
        const p = [0, 0, 0];
        p[a] = (s * size[a]) / 2;
        p[u] = (i / k - 0.5) * size[u];
        p[v] = (j / k - 0.5) * size[v];
        return vertex(p);
      };
      for (let i = 0; i < k; i++)
        for (let j = 0; j < k; j++) {
          const c00 = corner(i, j),
            c10 = corner(i + 1, j),
            c11 = corner(i + 1, j + 1),
            c01 = corner(i, j + 1);
          if (s > 0) faces.push([c00, c10, c11], [c00, c11, c01]);
          else faces.push([c00, c11, c10], [c00, c01, c11]);
        }
    }
  return { vertices, faces };
}

export function objText({ vertices, faces }) {
  return [...vertices.map((p) => `v ${p.join(" ")}`), ...faces.map((f) => `f ${f.map((i) => i + 1).join(" ")}`)].join("\n") + "\n";
}

/** Undirected edges [lower, higher] of the faces and how many faces each is in. */
export function edgeUses(faces) {
  const uses = new Map();
  for (const f of faces)
    for (let c = 0; c < 3; c++) {
      const a = f[c],
        b = f[(c + 1) % 3];
      const key = `${Math.min(a, b)},${Math.max(a, b)}`;
      uses.set(key, (uses.get(key) ?? 0) + 1);
    }
  return [...uses].map(([key, n]) => ({ edge: key.split(",").map(Number), n }));
}
