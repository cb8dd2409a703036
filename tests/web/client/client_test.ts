// A client generated from server/openapi.yaml (openapi-typescript's types for openapi-fetch),
// compiled by tsc with --strict against them: a request or an answer that the document does not
// describe does not compile. Run by client.mjs against a real forklift-server.
import createClient from "openapi-fetch";
import type { paths } from "./api.js";

// Node's, without its type package: only the two settings client.mjs passes.
declare const process: { env: { FORKLIFT_URL?: string; FORKLIFT_ADMIN_PASSWORD?: string } };

function check(cond: boolean, what: string): asserts cond {
  if (!cond) throw new Error(what);
}

const client = createClient<paths>({ baseUrl: process.env.FORKLIFT_URL });

// Log in.
const login = await client.POST("/api/login", { body: { username: "admin", password: process.env.FORKLIFT_ADMIN_PASSWORD ?? "" } });
check(login.data !== undefined, `login: ${login.response.status} ${JSON.stringify(login.error)}`);
check(login.data.role === "admin", `login: role ${login.data.role}`);
const token: string = login.data.token ?? "";
const auth = { headers: { Authorization: `Bearer ${token}` } };

// Add a pupil: 201 with the pupil and its Location.
const added = await client.POST("/api/pupils", { body: { name: "Ada Lovelace", email: "ada@example.org" }, ...auth });
check(added.data !== undefined, `add: ${added.response.status} ${JSON.stringify(added.error)}`);
check(added.response.status === 201, `add: status ${added.response.status}`);
const id: number = added.data.id ?? 0;
check(id > 0, `add: id ${id}`);
check(added.response.headers.get("Location") === `/api/pupils/${id}`, `add: Location ${added.response.headers.get("Location")}`);

// Read the history: the pupil, no sessions, no exams, no licence yet.
const history = await client.GET("/api/pupils/{id}/history", { params: { path: { id } }, ...auth });
check(history.data !== undefined, `history: ${history.response.status} ${JSON.stringify(history.error)}`);
check(history.data.pupil?.name === "Ada Lovelace", `history: pupil ${JSON.stringify(history.data.pupil)}`);
check(Array.isArray(history.data.sessions) && history.data.sessions.length === 0, "history: sessions");
check(Array.isArray(history.data.exams) && history.data.exams.length === 0, "history: exams");
check(history.data.licence === null, `history: licence ${JSON.stringify(history.data.licence)}`);

// The pupil in the paged list, found by name.
// (The list also answers CSV with format=csv: the JSON page is the object.)
const list = await client.GET("/api/pupils", { params: { query: { search: "lovelace", limit: 10 } }, ...auth });
const page = typeof list.data === "object" ? list.data : undefined;
check(page !== undefined && page.total === 1 && (page.pupils ?? []).some((p) => p.id === id),
      `list: ${JSON.stringify(list.data ?? list.error)}`);

// A refusal is the document's Error: a field the request does not take, named.
const refused = await client.POST("/api/pupils", { body: { name: "Bo", nmae: "Bo" } as { name: string }, ...auth });
check(refused.response.status === 400, `refused: status ${refused.response.status}`);
check(refused.error?.error.code === "bad_request" && refused.error.error.message.includes("'nmae'"),
      `refused: ${JSON.stringify(refused.error)}`);

// Without the token: 401, with the scheme to use.
const anonymous = await client.GET("/api/pupils/{id}/history", { params: { path: { id } } });
check(anonymous.response.status === 401, `anonymous: status ${anonymous.response.status}`);
check((anonymous.response.headers.get("WWW-Authenticate") ?? "").startsWith("Bearer"), "anonymous: no WWW-Authenticate");

console.log(`client: logged in, added pupil ${id}, read the history`);
