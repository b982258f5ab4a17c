// A client nobody here wrote against WEBBRIDGE's Foxglove protocol (issue 40; run by test/web_foxglove.sh):
// @foxglove/ws-protocol's FoxgloveClient (over the `ws` package: node 20 has no global WebSocket) lists the
// channels, subscribes, and @foxglove/rosmsg + @foxglove/rosmsg-serialization decode the ROS 1 messages from the
// advertised definitions. Checks: /tf agrees with XPERSim's ground truth at the same stamp; the overhead camera's
// channel carries JPEGs of the camera's size; the loop's progress decodes; a client that advertises or publishes
// is closed.
// usage: node test/foxglove_check.mjs WS_URL NS CAMERA_TOPIC WIDTHxHEIGHT
import wsProtocol from "@foxglove/ws-protocol"; // CommonJS: its named exports come through the default one
import rosmsg from "@foxglove/rosmsg";
import serialization from "@foxglove/rosmsg-serialization";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const { parse } = rosmsg;
const { MessageReader } = serialization;

const [url, ns, cameraTopic, size] = process.argv.slice(2);
const [wantWidth, wantHeight] = size.split("x").map(Number);
const want = {
  tf: "/tf",
  truth: `${ns}/xpersim/ground_truth`,
  image: `${cameraTopic}/compressed`,
  progress: `${ns}/loop_model/progress`,
};
const POSITION_TOLERANCE = 0.003; // m: ground truth moved on by its velocity over at most 50 ms
const failures = [];
const fail = (text) => failures.push(text);
const seconds = (t) => t.sec + t.nsec * 1e-9;

function connect() {
  const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  const state = { client, channels: new Map(), info: null, closed: null };
  client.on("serverInfo", (info) => (state.info = info));
  client.on("advertise", (channels) => channels.forEach((c) => state.channels.set(c.topic, c)));
  client.on("close", (event) => (state.closed = { code: event.code, reason: event.reason }));
  client.on("error", () => {});
  return state;
}

async function until(what, predicate, timeoutSeconds) {
  const end = Date.now() + timeoutSeconds * 1000;
  while (!predicate()) {
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await new Promise((resolve) => setTimeout(resolve, 50));
  }
}

/// Each ground-truth body against its /tf poses within 50 ms of the truth's stamp, the truth moved on by the body's
/// own velocity to each pose's stamp: the nearest of them, and the largest such distance over every body and truth.
/// The nearest, not the one at the nearest stamp: a body placed between experiments (the world restored, an object
/// relocated) jumps without time going on, and the frame of the same instant may be the one the queue dropped.
function compareWithTruth(tfByStamp, truths) {
  const stamps = [...tfByStamp.keys()].map(Number).sort((a, b) => a - b);
  let compared = 0, worst = 0, worstName = "", worstGap = 0;
  for (const truth of truths) {
    const stamp = seconds(truth.header.stamp);
    const near = stamps.filter((s) => Math.abs(s - stamp) <= 0.05);
    truth.names.forEach((name, i) => {
      const p = truth.poses[i].position, v = truth.velocities[i].linear;
      let best = null;
      for (const s of near) {
        const t = tfByStamp.get(s.toFixed(9)).get(name);
        if (!t || t.header.frame_id !== truth.header.frame_id) continue;
        const dt = s - stamp, q = t.transform.translation;
        const d = Math.hypot(p.x + v.x * dt - q.x, p.y + v.y * dt - q.y, p.z + v.z * dt - q.z);
        if (best === null || d < best.d) best = { d, dt };
      }
      if (best === null) return;
      compared += 1;
      if (best.d >= worst) [worst, worstName, worstGap] = [best.d, name, best.dt];
    });
  }
  return { compared, worst, worstName, worstGap };
}

/// Width and height from a JPEG's start-of-frame marker.
function jpegSize(bytes) {
  for (let i = 2; i + 9 < bytes.length;) {
    if (bytes[i] !== 0xff) return null;
    const marker = bytes[i + 1], length = (bytes[i + 2] << 8) | bytes[i + 3];
    if (marker >= 0xc0 && marker <= 0xc3) return { height: (bytes[i + 5] << 8) | bytes[i + 6], width: (bytes[i + 7] << 8) | bytes[i + 8] };
    i += 2 + length;
  }
  return null;
}

async function watch() {
  const s = connect();
  await until("serverInfo", () => s.info, 10);
  console.log(`serverInfo: ${s.info.name}, capabilities ${JSON.stringify(s.info.capabilities)}`);
  if (s.info.capabilities.includes("clientPublish")) fail("the server offers clientPublish without a token");
  await until(`channels ${Object.values(want).join(", ")}`, () => Object.values(want).every((t) => s.channels.has(t)), 90);
  console.log("channels:");
  for (const c of s.channels.values()) console.log(`  ${c.id} ${c.topic} ${c.encoding} ${c.schemaName} (${c.schema.length} bytes of definition)`);

  const readers = new Map(), topicOf = new Map(), got = { tf: new Map(), truth: [], image: null, progress: null, stampGap: 0 };
  for (const [key, topic] of Object.entries(want)) {
    const channel = s.channels.get(topic);
    readers.set(key, new MessageReader(parse(channel.schema, { ros2: false })));
    topicOf.set(s.client.subscribe(channel.id), key);
  }
  s.client.on("message", ({ subscriptionId, timestamp, data }) => {
    const key = topicOf.get(subscriptionId);
    const message = readers.get(key).readMessage(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
    if (key === "tf") {
      for (const t of message.transforms) {
        // Keyed to the nanosecond: a frame published at a placement is 1 ns after the tick's (xpersim.cpp).
        const stamp = seconds(t.header.stamp).toFixed(9);
        if (!got.tf.has(stamp)) got.tf.set(stamp, new Map());
        got.tf.get(stamp).set(t.child_frame_id, t);
        // The receive stamp is simulated time too: close to the transforms' own stamps.
        got.stampGap = Math.max(got.stampGap, Math.abs(Number(timestamp) * 1e-9 - seconds(t.header.stamp)));
      }
    } else if (key === "truth") {
      got.truth.push(message);
    } else {
      got[key] = message;
    }
  });
  await until("/tf, ground truth, an image and the progress", () => got.tf.size > 20 && got.truth.length > 5 && got.image && got.progress, 60);
  await new Promise((resolve) => setTimeout(resolve, 1000));
  s.client.close();

  const match = compareWithTruth(got.tf, got.truth);
  console.log(`/tf against ground truth: ${match.compared} poses compared; the largest distance ` +
    `${match.worst.toExponential(2)} m (${match.worstName}, stamps ${match.worstGap.toFixed(4)} s apart)`);
  if (match.compared === 0) fail("no /tf transform matched a ground-truth body within 50 ms");
  if (match.worst > POSITION_TOLERANCE) fail(`/tf is ${match.worst} m from ground truth for ${match.worstName}`);
  console.log(`receive stamps within ${got.stampGap.toFixed(3)} s of the transforms' stamps (simulated time)`);
  if (got.stampGap > 2) fail(`receive stamps are ${got.stampGap} s from the messages' simulated stamps`);

  const jpeg = got.image.data, jsize = jpegSize(jpeg);
  console.log(`${want.image}: format ${got.image.format}, ${jpeg.length} bytes, ${jsize ? `${jsize.width}x${jsize.height}` : "no size"}`);
  if (jpeg[0] !== 0xff || jpeg[1] !== 0xd8) fail("the compressed image is not a JPEG");
  if (!jsize || jsize.width !== wantWidth || jsize.height !== wantHeight) fail(`the JPEG is not ${size}`);
  console.log(`${want.progress}: state ${JSON.stringify(got.progress.state)}, experiment ${got.progress.experiment}`);
  if (typeof got.progress.state !== "string" || typeof got.progress.experiment !== "number") fail("the progress did not decode");
}

/// A client that tries to publish (advertise, then binary message data) is closed with the reason.
async function tryToPublish(how) {
  const s = connect();
  await until("serverInfo", () => s.info, 10);
  // Either the advertisement of a channel of its own, or message data on one straight away (48 bytes: a Twist).
  if (how === "advertise") {
    s.client.advertise({ topic: `${ns}/relocation/cmd_vel`, encoding: "ros1", schemaName: "geometry_msgs/Twist" });
  } else {
    s.client.sendMessage(1, new Uint8Array(48));
  }
  await until("the server to close a publishing client", () => s.closed, 10);
  console.log(`a client that tries to publish (${how}): closed with ${s.closed.code} '${s.closed.reason}'`);
  if (s.closed.code !== 1008 || !s.closed.reason.includes("read-only")) fail(`a publishing client (${how}) was not refused`);
}

try {
  await watch();
  await tryToPublish("advertise");
  await tryToPublish("message");
} catch (e) {
  fail(e.message);
}
for (const f of failures) console.log(`FAIL: ${f}`);
process.exit(failures.length ? 1 : 0);
