// Just enough of the host<->adapter framing (crates/wire, docs: `COBS(postcard(msg) ‖ CRC-16)
// ‖ 0x00`, CRC-16/IBM-3740, little-endian) to watch what the adapter answers, written here
// from the format rather than reusing the crate, so a framing bug on either side shows.

/** CRC-16/IBM-3740 (CCITT-FALSE): polynomial 0x1021, init 0xFFFF, not reflected, no xorout. */
export function crc16(bytes) {
  let crc = 0xffff;
  for (const b of bytes) {
    crc ^= b << 8;
    for (let i = 0; i < 8; i++) crc = crc & 0x8000 ? ((crc << 1) ^ 0x1021) & 0xffff : (crc << 1) & 0xffff;
  }
  return crc;
}

/** Consistent overhead byte stuffing, without the trailing delimiter. */
export function cobsEncode(data) {
  const out = [0];
  let codeAt = 0;
  let code = 1;
  for (const b of data) {
    if (b === 0) {
      out[codeAt] = code;
      codeAt = out.length;
      out.push(0);
      code = 1;
    } else {
      out.push(b);
      code += 1;
      if (code === 0xff) {
        out[codeAt] = code;
        codeAt = out.length;
        out.push(0);
        code = 1;
      }
    }
  }
  out[codeAt] = code;
  return out;
}

/** Inverse of {@link cobsEncode}; null when the bytes are not valid COBS. */
export function cobsDecode(enc) {
  const out = [];
  let i = 0;
  while (i < enc.length) {
    const code = enc[i];
    if (code === 0 || i + code > enc.length) return null;
    for (let j = 1; j < code; j++) out.push(enc[i + j]);
    i += code;
    if (code < 0xff && i < enc.length) out.push(0);
  }
  return out;
}

/** The frame of a request that is a bare enum variant (postcard: its index as one byte). */
export function unitRequestFrame(variantIndex) {
  const body = [variantIndex];
  const crc = crc16(body);
  return [...cobsEncode([...body, crc & 0xff, crc >> 8]), 0];
}

/** Response variant indices (crates/wire/src/schema.rs). */
export const RESPONSE = { hello: 0, error: 1, ack: 2, calibration: 3, streamStarted: 4, sample: 5, status: 6, background: 7, gyroSample: 9 };
/** Request variant indices. */
export const REQUEST = { getCalibration: 1, startStream: 4, getStatus: 6, getBackgroundStatus: 8, setBackground: 9 };

/**
 * Splits the adapter's byte stream, which starts at a frame boundary, at its 0x00 delimiters
 * (a partial frame at the end is ignored) and decodes each frame: { tag, body } when COBS and
 * CRC hold, { bad: reason } otherwise.
 */
export function decodeFrames(bytes) {
  const frames = [];
  let start = -1;
  for (let i = start + 1; i < bytes.length; i++) {
    if (bytes[i] !== 0) continue;
    const enc = bytes.slice(start + 1, i);
    start = i;
    if (!enc.length) continue;
    const raw = cobsDecode(enc);
    if (!raw || raw.length < 3) {
      frames.push({ bad: 'COBS' });
      continue;
    }
    const body = raw.slice(0, -2);
    const crc = crc16(body);
    if (raw[raw.length - 2] !== (crc & 0xff) || raw[raw.length - 1] !== crc >> 8) {
      frames.push({ bad: 'CRC' });
      continue;
    }
    frames.push({ tag: body[0], body });
  }
  return frames;
}

/** Little-endian f32 bytes. */
function f32le(values) {
  const view = new DataView(new ArrayBuffer(4 * values.length));
  values.forEach((v, i) => view.setFloat32(4 * i, v, true));
  return [...new Uint8Array(view.buffer)];
}

/** postcard varint (LEB128) of an unsigned integer. */
function varint(n) {
  const out = [];
  let v = n >>> 0;
  do {
    let b = v & 0x7f;
    v >>>= 7;
    if (v) b |= 0x80;
    out.push(b);
  } while (v);
  return out;
}

/** A frame around a postcard body. */
export function frame(body) {
  const crc = crc16(body);
  return [...cobsEncode([...body, crc & 0xff, crc >> 8]), 0];
}

/** Hello { protocol_version, schema_key }. */
export function helloFrame(protocolVersion, schemaKey) {
  return frame([0, ...varint(protocolVersion), ...varint(schemaKey)]);
}

/**
 * PutCalibration of a linear calibration ({ bias, matrix }; effect terms zero): protocol 3's
 * WireCalibration is 12 floats, then 16 effect floats and 15 + 27 orientation cross terms.
 */
export function putFrame(cal) {
  return frame([2, ...f32le([...cal.bias, ...cal.matrix.flat(), ...new Array(16 + 42).fill(0)])]);
}

/** Decodes the varint at `body[i]`: [value, next index]. */
function readVarint(body, i) {
  let v = 0;
  let shift = 0;
  for (;;) {
    const b = body[i++];
    v += (b & 0x7f) * 2 ** shift;
    shift += 7;
    if (!(b & 0x80)) return [v, i];
  }
}

/** StartStream { rate_divider }. */
export function startStreamFrame(rateDivider) {
  return frame([REQUEST.startStream, ...varint(rateDivider)]);
}

/**
 * A GyroSample response's body (protocol 8): { seq, raw: [yaw, roll, pitch] 14-bit counts,
 * slow: [yaw, roll, pitch] range bits, corrected: rad/s or null (no gyro calibration) }.
 */
export function decodeGyroSample(body) {
  let i = 1;
  const v = () => {
    const [x, j] = readVarint(body, i);
    i = j;
    return x;
  };
  const seq = v();
  const raw = [v(), v(), v()];
  const bits = body[i++];
  const slow = [0, 1, 2].map((k) => ((bits >> k) & 1) === 1);
  let corrected = null;
  if (body[i++] === 1) {
    const view = new DataView(Uint8Array.from(body.slice(i, i + 12)).buffer);
    corrected = [0, 1, 2].map((k) => view.getFloat32(4 * k, true));
  }
  return { seq, raw, slow, corrected };
}

/**
 * SetBackground (protocol 6): adoption and host-upload flags, then the budget's commit
 * interval (s of play, varint), commits per day (u8) and the fit interval (ms, varint).
 */
export function setBackgroundFrame({ adopt = true, replaceUploaded = false, commitIntervalS, commitsPerDay, fitIntervalMs }) {
  return frame([REQUEST.setBackground, adopt ? 1 : 0, replaceUploaded ? 1 : 0, ...varint(commitIntervalS), commitsPerDay, ...varint(fitIntervalMs)]);
}

/**
 * The head of a Background response (protocol 6's BackgroundReport), as far as the last
 * adoption: { settings, playS, moments, binsFilled, temperatureC, candidate, lastAdoption }.
 */
export function decodeBackgroundHead(body) {
  const view = new DataView(Uint8Array.from(body).buffer);
  let i = 2; // tag, phase
  const u8 = () => body[i++];
  const v = () => {
    const [x, j] = readVarint(body, i);
    i = j;
    return x;
  };
  const f32 = () => {
    const x = view.getFloat32(i, true);
    i += 4;
    return x;
  };
  const settings = { adopt: !!u8(), replaceUploaded: !!u8(), commitIntervalS: v(), commitsPerDay: u8(), fitIntervalMs: v() };
  u8(); // origin
  const playS = v();
  const moments = v();
  const binsFilled = u8();
  v(); // fresh bins
  const bins = v();
  i += bins; // bin moments
  const temperatureC = u8() ? f32() : null;
  if (u8()) {
    const gap = u8();
    if (gap <= 1) i += 2;
  }
  const candidate = u8() ? { candidateMg: f32(), liveMg: f32(), fitRmsMg: f32(), full: !!u8(), temperature: !!u8(), training: u8(), heldout: u8() } : null;
  const lastAdoption = u8() ? { atS: v(), beforeMg: f32(), afterMg: f32() } : null;
  return { settings, playS, moments, binsFilled, temperatureC, candidate, lastAdoption };
}

/**
 * Talks to the adapter over the emulated USB without the CLI (fast, for scripted set-ups such
 * as filling the calibration store): one request, then the first reply that is not a streamed
 * sample (a Nunchuk's or a MotionPlus's).
 */
export class RawHost {
  constructor(rig) {
    this.rig = rig;
    this.bytes = [];
    const forward = rig.usb.onData;
    rig.usb.onData = (b) => {
      this.bytes.push(...b);
      forward?.(b);
    };
  }

  async request(frameBytes, ms = 500) {
    this.bytes = [];
    this.rig.usb.write(frameBytes);
    let reply = null;
    await this.rig.board.runUntilTrue(() => {
      reply = decodeFrames(this.bytes).find((f) => f.tag !== RESPONSE.sample && f.tag !== RESPONSE.gyroSample) ?? null;
      return reply !== null;
    }, ms, 1);
    return reply;
  }

  /** Opens a session: learns the adapter's schema key from a first Hello, then matches it. */
  async hello(protocolVersion = 3) {
    const first = await this.request(helloFrame(protocolVersion, 0));
    if (first?.tag !== RESPONSE.hello) return false;
    const [, i] = readVarint(first.body, 1);
    const [key] = readVarint(first.body, i);
    const again = await this.request(helloFrame(protocolVersion, key));
    return again?.tag === RESPONSE.hello;
  }

  /** Stages and commits `cal`; true when both were acknowledged. */
  async putCommit(cal) {
    const put = await this.request(putFrame(cal));
    if (put?.tag !== RESPONSE.ack) return false;
    const commit = await this.request(frame([3]), 2000);
    return commit?.tag === RESPONSE.ack;
  }
}

