// Calls to strata-server's JSON API (server/http/http_api.hpp): the gRPC API's own request and
// response messages in protobuf's JSON mapping, so what the page shows is what a gRPC client
// gets. Failures become ApiErrors carrying the google.rpc.Status details. The page uses the
// API's page route, /viewer-api/, which answers a refused call with HTTP 200 and the Status
// in the body: the browser's console then logs no failed load for an error the page shows.

const TOKEN_KEY = 'strata.viewer.token';

// Canonical names of the gRPC status codes, by number.
const CODE_NAMES = [
  'OK', 'CANCELLED', 'UNKNOWN', 'INVALID_ARGUMENT', 'DEADLINE_EXCEEDED', 'NOT_FOUND',
  'ALREADY_EXISTS', 'PERMISSION_DENIED', 'RESOURCE_EXHAUSTED', 'FAILED_PRECONDITION',
  'ABORTED', 'OUT_OF_RANGE', 'UNIMPLEMENTED', 'INTERNAL', 'UNAVAILABLE', 'DATA_LOSS',
  'UNAUTHENTICATED',
];

// A failed call: the gRPC code's name, the ErrorInfo reason and metadata, the message, and the
// BadRequest's field violations.
export class ApiError extends Error {
  constructor({ code = 'UNKNOWN', reason = '', message = '', metadata = {}, violations = [] }) {
    super(message);
    this.code = code;
    this.reason = reason || code;
    this.metadata = metadata;
    this.violations = violations;
  }
}

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || '';
}

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
}

// The ApiError of a google.rpc.Status (the body of a failed call).
export function errorFromStatus(status) {
  const details = status.details || [];
  const info = details.find((d) => (d['@type'] || '').endsWith('/google.rpc.ErrorInfo')) || {};
  const bad = details.find((d) => (d['@type'] || '').endsWith('/google.rpc.BadRequest'));
  return new ApiError({
    code: CODE_NAMES[status.code] || String(status.code),
    reason: info.reason,
    message: status.message,
    metadata: info.metadata || {},
    violations: bad ? bad.field_violations || [] : [],
  });
}

// The ApiError of a RecentPlan's error (strata.v1.PlanError).
export function errorFromPlanError(error) {
  return new ApiError({
    code: error.code, reason: error.reason, message: error.message, metadata: error.metadata || {},
  });
}

// Calls `method` ("strata.v1.MapService/ListMaps") with `request`; resolves to the response
// message, rejects with an ApiError.
export async function call(method, request = {}) {
  const headers = { 'Content-Type': 'application/json' };
  const bearer = token();
  if (bearer) headers.Authorization = `Bearer ${bearer}`;
  let response;
  try {
    response = await fetch(`/viewer-api/${method}`, {
      method: 'POST', headers, body: JSON.stringify(request),
    });
  } catch (e) {
    throw new ApiError({ code: 'UNAVAILABLE', reason: 'UNREACHABLE', message: `the server does not answer (${e.message})` });
  }
  // The HTTP server's own refusals keep their status: 413 (a google.rpc.Status) and 503 (text).
  const text = await response.text();
  let body;
  try {
    body = JSON.parse(text);
  } catch (e) {
    throw new ApiError({ code: 'UNKNOWN', message: `HTTP ${response.status}: ${text.slice(0, 200)}` });
  }
  if (!response.ok) throw errorFromStatus(body);
  if (body.error) throw errorFromStatus(body.error);
  return body.response;
}
