// The wire protocol's types, generated from the server's OpenAPI document (wire.gen.ts; `npm run
// gen:api` rewrites it, `npm run check:api` fails when it is stale). Views import from here, not
// hand-written copies, so a server change the front end does not follow fails tsc.
import type { components, paths } from "./wire.gen";

export type Schemas = components["schemas"];
export type ErrorBody = Schemas["ErrorBody"];
export type Job = Schemas["Job"];
export type KelvinObject = Schemas["KelvinObject"];
export type KelvinStats = Schemas["KelvinStats"];
export type RepairReport = Schemas["RepairReport"];
export type SurfaceCheck = Schemas["SurfaceCheck"];
export type Sigma = Schemas["Sigma"];
export type AxisTerm = Schemas["AxisTerm"];
export type CbfFrames = Schemas["CbfFrames"];
export type LevelsetsResult = Schemas["LevelsetsResult"];
export type WsClientMessage = Schemas["WsClientMessage"];
export type WsServerMessage = Schemas["WsServerMessage"];

/** The JSON body of a route's 200 (or 201/202) response. */
type JsonOf<R> = R extends { content: { "application/json": infer B } } ? B : never;
type Ok<Op> = Op extends { responses: infer Rs } ? JsonOf<Rs[keyof Rs & (200 | 201 | 202)]> : never;
export type GetResponse<P extends keyof paths> = Ok<paths[P]["get"]>;
export type PostResponse<P extends keyof paths> = Ok<paths[P]["post"]>;

export type Limits = GetResponse<"/api/limits">;
export type Estimate = PostResponse<"/api/kelvin/estimate">;
