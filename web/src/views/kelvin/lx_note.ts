// What l_x means for the object at hand. l_x is the edge length of the field's tetrahedra at the
// surface, in metres: the same number is fine on a 1 m object and meaningless on a 1 cm one (the
// server then says only "lx is larger than the object"). The note relates it to the object's
// diagonal and offers the value an upload starts from.
import type { Estimate } from "./object_source";

/** Coarser than this fraction of the diagonal, the field cannot show the object's shape. */
const COARSE = 1 / 8;
/** The l_x an upload starts from: a thirtieth of the diagonal, coarser if over this server's
 *  budget (lx_for_budget, at least its min_lx), rounded up to two significant digits. */
export function suggestedLx(e: Pick<Estimate, "diagonal" | "lx_for_budget">): number {
  const lx = Math.max(e.lx_for_budget, e.diagonal / 30);
  const step = 10 ** (Math.floor(Math.log10(lx)) - 1);
  return Number((Math.ceil(lx / step) * step).toPrecision(12));
}

const m = (x: number) => `${Number(x.toPrecision(3))} m`;

/** The note under l_x: empty while l_x resolves the object, else what it means here and the value
 *  to use (null when l_x is that value already). */
export function lxNote(e: Pick<Estimate, "diagonal" | "lx_for_budget" | "min_lx">, lx: number): { text: string; suggestion: number | null } {
  if (!(e.diagonal > 0) || lx <= COARSE * e.diagonal) return { text: "", suggestion: null };
  const s = suggestedLx(e);
  const ratio = lx / e.diagonal;
  const size =
    ratio >= 1
      ? `${Number(ratio.toPrecision(2))}× the object's diagonal (${m(e.diagonal)})`
      : `1/${Number((1 / ratio).toPrecision(2))} of the object's diagonal (${m(e.diagonal)})`;
  const why = s > e.diagonal / 30 ? (s === e.min_lx ? "this server's smallest l_x" : "the finest within this server's budget") : "a thirtieth of the diagonal";
  return {
    text: `l_x is the edge length of the field's tetrahedra at the surface: ${m(lx)} is ${size}, too coarse to resolve its shape. Suggested: ${m(s)} (${why}).`,
    suggestion: s === lx ? null : s,
  };
}
