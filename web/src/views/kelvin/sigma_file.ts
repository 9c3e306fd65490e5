// σ regions as a file, in the format of the wrench cases in assets/ (wrench_case_*.json):
// {"comment", "mesh": {"asset"}, "lx", "sigma": {constant | axis, brushes}}, plus the cases'
// optional "center", "feature_angle", "grading" and "query". A link whose σ is too long for a URL refers to
// such a file by the number of brush stamps and a digest of them.
import { presets, packBrushes, type Brush, type PresetName, type SigmaBody } from "./sigma";

export class SigmaFileError extends Error {
  constructor(
    readonly field: string,
    message: string,
  ) {
    super(`${field}: ${message}`);
  }
}

export interface SigmaFileContent {
  /** The built-in asset, or the uploaded file's name. */
  mesh: { asset: string } | { upload: string };
  lx?: number;
  preset: PresetName;
  base: number;
  brushes: Brush[];
}

/** The file's text: the case format, with full-precision brushes (the link's are rounded). */
export function sigmaFileText(c: SigmaFileContent, body: SigmaBody): string {
  const lines = [
    `  "comment": ${JSON.stringify(`σ painted in the distlab inspector (${c.brushes.length} brush stamps)`)},`,
    `  "mesh": ${JSON.stringify(c.mesh)},`,
    ...(c.lx === undefined ? [] : [`  "lx": ${c.lx},`]),
    `  "sigma": {`,
    [
      ...(body.constant === undefined ? [] : [`    "constant": ${body.constant}`]),
      ...(body.axis === undefined ? [] : [`    "axis": ${JSON.stringify(body.axis)}`]),
      ...(body.brushes?.length ? [`    "brushes": [\n${body.brushes.map((b) => `      ${JSON.stringify(b)}`).join(",\n")}\n    ]`] : []),
    ].join(",\n"),
    `  }`,
  ];
  return `{\n${lines.join("\n")}\n}\n`;
}

const isNum = (x: unknown): x is number => typeof x === "number" && Number.isFinite(x);
function keys(o: Record<string, unknown>, allowed: string[], where: string): void {
  const bad = Object.keys(o).find((k) => !allowed.includes(k));
  if (bad !== undefined) throw new SigmaFileError(where ? `${where}.${bad}` : bad, "unknown key");
}
function object(v: unknown, field: string): Record<string, unknown> {
  if (!v || typeof v !== "object" || Array.isArray(v)) throw new SigmaFileError(field, "must be an object");
  return v as Record<string, unknown>;
}
function vec3(v: unknown, field: string): [number, number, number] {
  if (!Array.isArray(v) || v.length !== 3 || !v.every(isNum)) throw new SigmaFileError(field, "must be 3 finite numbers");
  return [v[0], v[1], v[2]];
}

/** Reads a σ file (a wrench case file too); refuses unknown keys and bad values, naming them. */
export function parseSigmaFile(text: string): SigmaFileContent {
  let raw: unknown;
  try {
    raw = JSON.parse(text);
  } catch (e) {
    throw new SigmaFileError("file", `not JSON (${(e as Error).message})`);
  }
  const o = object(raw, "file");
  keys(o, ["comment", "mesh", "lx", "center", "feature_angle", "grading", "sigma", "query"], "");
  const mesh = object(o.mesh, "mesh");
  keys(mesh, ["asset", "upload"], "mesh");
  let m: SigmaFileContent["mesh"];
  if (typeof mesh.asset === "string" && mesh.upload === undefined) m = { asset: mesh.asset };
  else if (typeof mesh.upload === "string" && mesh.asset === undefined) m = { upload: mesh.upload };
  else throw new SigmaFileError("mesh", 'needs "asset" (a built-in object) or "upload" (a file name)');
  if (o.lx !== undefined && !(isNum(o.lx) && o.lx > 0)) throw new SigmaFileError("lx", "must be a positive number (metres)");
  const sigma = object(o.sigma, "sigma");
  keys(sigma, ["constant", "axis", "brushes"], "sigma");
  if (sigma.constant !== undefined && !isNum(sigma.constant)) throw new SigmaFileError("sigma.constant", "must be a finite number");
  let preset: PresetName = "none";
  if (sigma.axis !== undefined) {
    // This view composes σ from a wrench case's axis terms or a constant, plus brushes.
    const match = (Object.keys(presets) as Array<Exclude<PresetName, "none">>).find(
      (p) => JSON.stringify(presets[p].sigma.axis) === JSON.stringify(sigma.axis) && presets[p].sigma.constant === sigma.constant,
    );
    if (!match) throw new SigmaFileError("sigma.axis", "this view shows axis terms of the wrench cases (a), (b), (c) only");
    preset = match;
  }
  const list = sigma.brushes ?? [];
  if (!Array.isArray(list)) throw new SigmaFileError("sigma.brushes", "must be a list");
  const brushes = list.map((b, i): Brush => {
    const f = `sigma.brushes[${i}]`;
    const o = object(b, f);
    keys(o, ["center", "radius", "value", "falloff", "mode"], f);
    if (!(isNum(o.radius) && o.radius >= 0)) throw new SigmaFileError(`${f}.radius`, "must be a number ≥ 0");
    if (!isNum(o.value)) throw new SigmaFileError(`${f}.value`, "must be a finite number");
    const falloff = o.falloff ?? 0;
    if (!(isNum(falloff) && falloff >= 0)) throw new SigmaFileError(`${f}.falloff`, "must be a number ≥ 0");
    if (o.mode !== undefined && o.mode !== "add" && o.mode !== "towards") throw new SigmaFileError(`${f}.mode`, 'must be "add" or "towards"');
    return { center: vec3(o.center, `${f}.center`), radius: o.radius, value: o.value, falloff, ...(o.mode === "towards" ? { mode: "towards" as const } : {}) };
  });
  return { mesh: m, lx: o.lx as number | undefined, preset, base: preset === "none" ? ((sigma.constant as number | undefined) ?? 0) : 0, brushes };
}

/** What a link records instead of brushes too many for a URL: their number and a digest (the
 *  first 16 hex digits of SHA-256 over the link's rounded form of them). */
export async function brushesDigest(brushes: Brush[]): Promise<string> {
  const bytes = new TextEncoder().encode(JSON.stringify(packBrushes(brushes)));
  const d = new Uint8Array(await crypto.subtle.digest("SHA-256", bytes));
  return Array.from(d.subarray(0, 8), (b) => b.toString(16).padStart(2, "0")).join("");
}
