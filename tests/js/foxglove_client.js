// A line-oriented driver of the official Foxglove WebSocket protocol client (@foxglove/ws-protocol) for
// the Python tests (tests/bridge): every request is one JSON line on stdin, every answer one JSON line on
// stdout. The protocol is spoken by FoxgloveClient only; this file records what it emits and hands the
// payloads over as base64, so the tests decode and judge them with rclpy.
//
// Requests: {"id": n, "cmd": NAME, ...}; answers: {"id": n, "ok": true, ...} or {"id": n, "ok": false,
// "error": "..."}. Commands that wait take "timeout" (seconds) and fail naming what they waited for.
"use strict";

const readline = require("readline");
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const WebSocket = require("ws");

const state = {
  client: null,
  socket: null,
  serverInfo: null,
  closed: null,
  errors: [],
  channels: new Map(), // topic -> channel
  services: new Map(), // name -> service
  subscriptions: new Map(), // subscription id -> {topic, messages: [{timestamp, data}]}
  statuses: [],
  parameterValues: [], // every parameterValues event, in order
  responses: new Map(), // call id -> {response?: base64, failure?: message}
  graphUpdates: [],
  times: [],
  nextCallId: 1,
};

function b64(view) {
  return Buffer.from(view.buffer, view.byteOffset, view.byteLength).toString("base64");
}

function until(what, predicate, timeout) {
  return new Promise((resolve, reject) => {
    const deadline = Date.now() + timeout * 1000;
    const look = () => {
      let value;
      try {
        value = predicate();
      } catch (error) {
        reject(error);
        return;
      }
      if (value !== undefined && value !== null && value !== false) {
        resolve(value);
      } else if (state.closed !== null) {
        // The socket's errors say why it closed (a TLS refusal: "self-signed certificate").
        const why = state.errors.length ? `; errors: ${state.errors.join("; ")}` : "";
        reject(new Error(`connection closed (${state.closed}${why}) while waiting for ${what}`));
      } else if (Date.now() > deadline) {
        reject(new Error(`no ${what} within ${timeout} s`));
      } else {
        setTimeout(look, 10);
      }
    };
    look();
  });
}

function connect({ url, subprotocol, timeout }) {
  const socket = new WebSocket(url, [subprotocol]);
  const client = new FoxgloveClient({ ws: socket });
  state.socket = socket;
  state.client = client;
  client.on("error", (error) => state.errors.push(String(error && error.message ? error.message : error)));
  client.on("close", (event) => {
    state.closed = `code ${event.code}${event.reason ? ": " + event.reason : ""}`;
  });
  client.on("serverInfo", (info) => {
    state.serverInfo = info;
  });
  client.on("status", (status) => state.statuses.push(status));
  client.on("advertise", (channels) => {
    for (const channel of channels) state.channels.set(channel.topic, channel);
  });
  client.on("unadvertise", (ids) => {
    for (const [topic, channel] of state.channels) if (ids.includes(channel.id)) state.channels.delete(topic);
  });
  client.on("advertiseServices", (services) => {
    for (const service of services) state.services.set(service.name, service);
  });
  client.on("unadvertiseServices", (ids) => {
    for (const [name, service] of state.services) if (ids.includes(service.id)) state.services.delete(name);
  });
  client.on("message", (event) => {
    const subscription = state.subscriptions.get(event.subscriptionId);
    if (subscription) {
      subscription.messages.push({ timestamp: event.timestamp.toString(), data: b64(event.data) });
    }
  });
  client.on("parameterValues", (event) => state.parameterValues.push(event));
  client.on("serviceCallResponse", (event) => {
    state.responses.set(event.callId, { encoding: event.encoding, response: b64(event.data) });
  });
  client.on("serviceCallFailure", (event) => state.responses.set(event.callId, { failure: event.message }));
  client.on("connectionGraphUpdate", (event) => state.graphUpdates.push(event));
  client.on("time", (event) => state.times.push(event.timestamp.toString()));
  return until("serverInfo", () => state.serverInfo, timeout).then((info) => ({
    serverInfo: info,
    protocol: socket.protocol,
  }));
}

function channelOf(topic, timeout) {
  return until(`advertisement of ${topic}`, () => state.channels.get(topic), timeout);
}

const commands = {
  connect,

  async channels({ topics, timeout }) {
    const found = {};
    for (const topic of topics) found[topic] = await channelOf(topic, timeout);
    return { channels: found };
  },

  // Every channel advertised so far.
  channelList() {
    return { channels: [...state.channels.values()] };
  },

  // How many messages each subscription has received so far.
  counts() {
    const counts = {};
    for (const [id, entry] of state.subscriptions) counts[entry.topic] = entry.messages.length;
    return { counts };
  },

  async subscribe({ topic, timeout }) {
    const channel = await channelOf(topic, timeout);
    const subscription = state.client.subscribe(channel.id);
    state.subscriptions.set(subscription, { topic, messages: [] });
    return { subscription, channel };
  },

  // Messages of a subscription from index `since` on, once at least `count` of them have arrived.
  async messages({ subscription, since = 0, count = 1, timeout }) {
    const entry = state.subscriptions.get(subscription);
    if (!entry) throw new Error(`no subscription ${subscription}`);
    await until(
      `${count} message(s) on ${entry.topic} after #${since}`,
      () => entry.messages.length - since >= count,
      timeout,
    );
    return { messages: entry.messages.slice(since) };
  },

  unsubscribe({ subscription }) {
    state.client.unsubscribe(subscription);
    return {};
  },

  async services({ names, timeout }) {
    const found = {};
    for (const name of names) {
      found[name] = await until(`service ${name}`, () => state.services.get(name), timeout);
    }
    return { services: found };
  },

  // Call a service by name with a CDR request (base64); the answer is the response or the failure.
  async call({ name, request, timeout }) {
    const service = await until(`service ${name}`, () => state.services.get(name), timeout);
    const callId = state.nextCallId++;
    state.client.sendServiceCallRequest({
      serviceId: service.id,
      callId,
      encoding: "cdr",
      data: new Uint8Array(Buffer.from(request, "base64")),
    });
    return await until(`answer to call ${callId} of ${name}`, () => state.responses.get(callId), timeout);
  },

  // A service call by id, as a client that guesses ids would send it (to see the refusal).
  async callById({ serviceId, request, timeout }) {
    const callId = state.nextCallId++;
    state.client.sendServiceCallRequest({
      serviceId,
      callId,
      encoding: "cdr",
      data: new Uint8Array(Buffer.from(request, "base64")),
    });
    return await until(`answer to call ${callId} of service ${serviceId}`, () => state.responses.get(callId), timeout);
  },

  async getParameters({ names, requestId, timeout }) {
    state.client.getParameters(names, requestId);
    const values = await until(
      `parameterValues ${requestId}`,
      () => state.parameterValues.find((v) => v.id === requestId),
      timeout,
    );
    return { parameters: values.parameters };
  },

  async setParameters({ parameters, requestId, timeout }) {
    state.client.setParameters(parameters, requestId);
    const values = await until(
      `parameterValues ${requestId}`,
      () => state.parameterValues.find((v) => v.id === requestId),
      timeout,
    );
    return { parameters: values.parameters };
  },

  subscribeParameterUpdates({ names }) {
    state.client.subscribeParameterUpdates(names);
    return {};
  },

  // Parameter values that arrived without a request id (updates), from index `since` of all values.
  async parameterUpdates({ since = 0, name, timeout }) {
    const updates = () =>
      state.parameterValues
        .slice(since)
        .filter((v) => v.id === undefined)
        .flatMap((v) => v.parameters);
    await until(`an update of ${name}`, () => updates().some((p) => p.name === name), timeout);
    return { parameters: updates(), next: state.parameterValues.length };
  },

  mark() {
    return {
      statuses: state.statuses.length,
      parameterValues: state.parameterValues.length,
      graphUpdates: state.graphUpdates.length,
      times: state.times.length,
    };
  },

  // Status messages from index `since`, once one of them contains `contains` (if given).
  async statuses({ since = 0, contains, timeout }) {
    if (contains) {
      await until(
        `a status containing ${JSON.stringify(contains)}`,
        () => state.statuses.slice(since).some((s) => s.message.includes(contains)),
        timeout,
      );
    }
    return { statuses: state.statuses.slice(since) };
  },

  advertise({ topic, schemaName, encoding = "cdr" }) {
    return { channelId: state.client.advertise({ topic, encoding, schemaName }) };
  },

  publish({ channelId, data }) {
    state.client.sendMessage(channelId, new Uint8Array(Buffer.from(data, "base64")));
    return {};
  },

  unadvertise({ channelId }) {
    state.client.unadvertise(channelId);
    return {};
  },

  subscribeConnectionGraph() {
    state.client.subscribeConnectionGraph();
    return {};
  },

  async graph({ since = 0, timeout }) {
    await until("a connection graph update", () => state.graphUpdates.length > since, timeout);
    return { updates: state.graphUpdates.slice(since) };
  },

  async times({ since = 0, count = 1, timeout }) {
    await until(`${count} time message(s)`, () => state.times.length - since >= count, timeout);
    return { times: state.times.slice(since) };
  },

  errors() {
    return { errors: state.errors, closed: state.closed };
  },

  close() {
    if (state.client) state.client.close();
    return {};
  },
};

const input = readline.createInterface({ input: process.stdin });
input.on("line", (line) => {
  let request;
  try {
    request = JSON.parse(line);
  } catch (error) {
    process.stdout.write(JSON.stringify({ id: null, ok: false, error: `bad request line: ${error}` }) + "\n");
    return;
  }
  const handler = commands[request.cmd];
  Promise.resolve()
    .then(() => {
      if (!handler) throw new Error(`unknown command ${request.cmd}`);
      return handler(request);
    })
    .then(
      (result) => process.stdout.write(JSON.stringify({ id: request.id, ok: true, ...result }) + "\n"),
      (error) =>
        process.stdout.write(
          JSON.stringify({ id: request.id, ok: false, error: String(error && error.message ? error.message : error) }) +
            "\n",
        ),
    );
});
input.on("close", () => {
  if (state.client) state.client.close();
  process.exit(0);
});
