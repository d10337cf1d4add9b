// node-opcua's client against the feeder OPC UA gateway: what a third-party PLC-side stack sees.
//
// Usage: node opcua_secure_client.js '{"url": ..., "user": ..., "password": ..., "pki": ..., "key": ...,
//   "viewer": ...}'
// Prints one JSON line (node-opcua's own log lines go before it): the endpoints GetEndpoints lists, and
// for each attempt whether a session opened (and what it read) or the error that refused it; with a
// viewer (an Observer, the same password), what the viewer and the user may do (rights); with
// lockout_failures and lockout_s, the gateway's login lockout from this address (last: it locks host B). The test
// judges; this script only reports. node-opcua refuses on its side to send a token or use an endpoint the
// server does not list; tests/cell/scripts/opcua_raw_probe.py sends those anyway.
"use strict";

const crypto = require("crypto");

const {
  OPCUAClient,
  MessageSecurityMode,
  SecurityPolicy,
  AttributeIds,
  UserTokenType,
} = require("node-opcua-client");
// The client's own certificate store: node-opcua-client's dependency, at the version it was locked with.
const { OPCUACertificateManager } = require(
  require.resolve("node-opcua-certificate-manager", { paths: [require.resolve("node-opcua-client")] }),
);

const NAMESPACE_URI = "urn:feeder:cell";
const PRODUCT_NAME = "ns=0;i=2261"; // Server/ServerStatus/BuildInfo/ProductName
const NAMESPACE_ARRAY = "ns=0;i=2255";

function errorText(error) {
  return String((error && (error.message || error)) || "unknown").split("\n")[0];
}

async function attempt(args, certificateManager, mode, policy, identity, own = {}) {
  const client = OPCUAClient.create({
    ...own, // a given client certificate and key, and the ApplicationUri it claims
    applicationName: "feeder-test-plc",
    securityMode: mode,
    securityPolicy: policy,
    // false: ask for the channel and the session even when no endpoint offers them, so a refusal
    // is the server's, not this client's.
    endpointMustExist: false,
    connectionStrategy: { maxRetry: 0, initialDelay: 100, maxDelay: 200 },
    requestedSessionTimeout: 60000,
    clientCertificateManager: certificateManager,
  });
  const outcome = { ok: false };
  try {
    await client.connect(args.url);
  } catch (error) {
    outcome.stage = "connect";
    outcome.error = errorText(error);
    return outcome;
  }
  try {
    const session = await client.createSession(identity);
    try {
      const namespaces = (await session.read({ nodeId: NAMESPACE_ARRAY, attributeId: AttributeIds.Value }))
        .value.value;
      const index = namespaces.indexOf(NAMESPACE_URI);
      const product = await session.read({ nodeId: PRODUCT_NAME, attributeId: AttributeIds.Value });
      const online = await session.read({
        nodeId: `ns=${index};s=${args.key}.Status.Online`,
        attributeId: AttributeIds.Value,
      });
      outcome.ok = true;
      outcome.product_name = product.value.value;
      outcome.online_status = online.statusCode.name;
      outcome.online = online.value.value;
    } finally {
      await session.close();
    }
  } catch (error) {
    outcome.stage = "session";
    outcome.error = errorText(error);
  } finally {
    await client.disconnect();
  }
  return outcome;
}

// What a logged-in user may do: a PackML command's answer, and the role attributes of that method.
async function rights(args, certificateManager, identity) {
  const client = OPCUAClient.create({
    applicationName: "feeder-test-plc",
    securityMode: MessageSecurityMode.SignAndEncrypt,
    securityPolicy: SecurityPolicy.Basic256Sha256,
    endpointMustExist: false,
    connectionStrategy: { maxRetry: 0, initialDelay: 100, maxDelay: 200 },
    requestedSessionTimeout: 60000,
    clientCertificateManager: certificateManager,
  });
  const outcome = { ok: false };
  try {
    await client.connect(args.url);
    const session = await client.createSession(identity);
    try {
      const namespaces = (await session.read({ nodeId: NAMESPACE_ARRAY, attributeId: AttributeIds.Value }))
        .value.value;
      const index = namespaces.indexOf(NAMESPACE_URI);
      const stop = `ns=${index};s=${args.key}.Stop`;
      const result = await session.call({ objectId: `ns=${index};s=${args.key}`, methodId: stop, inputArguments: [] });
      outcome.stop = result.statusCode.name;
      outcome.stop_message = result.outputArguments.length ? result.outputArguments[0].value : "";
      const read = async (attributeId) => session.read({ nodeId: stop, attributeId });
      outcome.user_executable = (await read(AttributeIds.UserExecutable)).value.value;
      const permissions = (dataValue) =>
        (dataValue.value.value || []).map((p) => ({ role: p.roleId.toString(), permissions: p.permissions }));
      outcome.role_permissions = permissions(await read(AttributeIds.RolePermissions));
      outcome.user_role_permissions = permissions(await read(AttributeIds.UserRolePermissions));
      outcome.ok = true;
    } finally {
      await session.close();
    }
  } catch (error) {
    outcome.error = errorText(error);
  } finally {
    await client.disconnect();
  }
  return outcome;
}

async function endpoints(args, certificateManager) {
  const client = OPCUAClient.create({
    applicationName: "feeder-test-plc",
    endpointMustExist: false,
    connectionStrategy: { maxRetry: 0, initialDelay: 100, maxDelay: 200 },
    clientCertificateManager: certificateManager,
  });
  await client.connect(args.url);
  try {
    return (await client.getEndpoints()).map((e) => ({
      mode: MessageSecurityMode[e.securityMode],
      policy: e.securityPolicyUri.split("#").pop(),
      tokens: (e.userIdentityTokens || []).map((t) => UserTokenType[t.tokenType]),
      server_certificate_sha256: e.serverCertificate
        ? crypto.createHash("sha256").update(e.serverCertificate).digest("hex")
        : "",
    }));
  } finally {
    await client.disconnect();
  }
}

async function main() {
  const args = JSON.parse(process.argv[2]);
  // Its own PKI in the test's folder: a fresh client certificate, the server's accepted on first sight
  // (the gateway's trust list is what the test exercises, not this client's).
  const certificateManager = new OPCUACertificateManager({
    rootFolder: args.pki,
    automaticallyAcceptUnknownCertificate: true,
  });
  await certificateManager.initialize();
  const user = { type: UserTokenType.UserName, userName: args.user, password: args.password };
  const wrong = { type: UserTokenType.UserName, userName: args.user, password: `${args.password}-wrong` };
  const anonymous = { type: UserTokenType.Anonymous };
  const secure = [MessageSecurityMode.SignAndEncrypt, SecurityPolicy.Basic256Sha256];
  const none = [MessageSecurityMode.None, SecurityPolicy.None];
  const report = { endpoints: await endpoints(args, certificateManager) };
  report.secure_user = await attempt(args, certificateManager, ...secure, user);
  report.secure_anonymous = await attempt(args, certificateManager, ...secure, anonymous);
  report.secure_wrong_password = await attempt(args, certificateManager, ...secure, wrong);
  report.none_user = await attempt(args, certificateManager, ...none, user);
  // A user name the users file does not have: refused like a wrong password (and as slowly).
  report.unknown_user = await attempt(args, certificateManager, ...secure, {
    type: UserTokenType.UserName,
    userName: "nobody",
    password: args.password,
  });
  if (args.viewer) {
    const viewer = { type: UserTokenType.UserName, userName: args.viewer, password: args.password };
    report.viewer_rights = await rights(args, certificateManager, viewer);
    report.user_rights = await rights(args, certificateManager, user);
  }
  // Client certificates the gateway must check for themselves (no trust list): each one's session.
  report.certificates = {};
  for (const [name, own] of Object.entries(args.certificates || {})) {
    report.certificates[name] = await attempt(args, certificateManager, ...secure, user, {
      certificateFile: own.cert,
      privateKeyFile: own.key,
      applicationUri: own.uri,
    });
  }
  if (args.lockout_failures) {
    // Past login_failures wrong passwords this address is locked out: even the right one is refused
    // until login_lockout has passed, then it works.
    report.lockout = { wrong: [] };
    for (let i = 0; i <= args.lockout_failures; i += 1) {
      report.lockout.wrong.push((await attempt(args, certificateManager, ...secure, wrong)).ok);
    }
    report.lockout.right_while_locked = await attempt(args, certificateManager, ...secure, user);
    await new Promise((resolve) => setTimeout(resolve, args.lockout_s * 1000 + 500));
    report.lockout.right_after = await attempt(args, certificateManager, ...secure, user);
  }
  await certificateManager.dispose();
  process.stdout.write(JSON.stringify(report) + "\n");
}

main().then(
  () => process.exit(0),
  (error) => {
    process.stdout.write(JSON.stringify({ error: errorText(error) }) + "\n");
    process.exit(1);
  },
);
