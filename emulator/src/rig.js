// One emulated adapter on the bench: the board, a Nunchuk on I²C0, a Wii Remote on I²C1, and
// a USB host whose CDC pipe is a pseudo-terminal for the real `wiical` CLI.

import { spawn } from 'node:child_process';
import { Board } from './board.js';
import { Nunchuk } from './nunchuk.js';
import { MotionPlus } from './motionplus.js';
import { WiiRemote } from './wiimote.js';
import { UsbCdcHost } from './usb-host.js';
import { PtyBridge } from './pty.js';

/**
 * A scripted motion: the Nunchuk is turned through a set of poses, each held for `holdMs`
 * (so that every pose is read several times by the adapter and by the Wii Remote). Counts
 * follow a Nunchuk with the given zero and sensitivity plus a small cross-axis term, so a
 * calibration visibly changes them.
 */
export function scriptedMotion({ zero = [508, 516, 520], perG = [204, 200, 204], holdMs = 40 } = {}) {
  const poses = [
    [0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, -1], [-1, 0, 0], [0, -1, 0],
    [0.6, 0.0, 0.8], [0.0, -0.6, 0.8], [0.5, 0.5, 0.7071], [-0.3, 0.4, -0.866],
  ];
  return (tNs) => {
    const k = Math.floor(tNs / (holdMs * 1e6));
    const g = poses[k % poses.length];
    const accel = [0, 1, 2].map((i) => Math.round(zero[i] + perG[i] * g[i] + 3 * g[(i + 1) % 3]));
    return { accel, stick: [0x80 + (k % 5) * 10, 0x7f - (k % 3) * 20], c: k % 4 === 1, z: k % 3 === 2, pose: k };
  };
}

export class Rig {
  /** `motionplus` (its options): a MotionPlus on I²C0 instead of the Nunchuk (with
   * `motionplus.nunchuk`, a Nunchuk in its port), and a Wii Remote that does the MotionPlus's
   * activation dance (in the mode `remote.motionplusMode`, 0x04 unless told). */
  constructor({ elfBytes = null, uf2Bytes = null, flashImage = null, wiical, link, nunchuk = {}, remote = {}, motionplus = null }) {
    this.board = new Board({ elfBytes, uf2Bytes, flashImage });
    if (motionplus) {
      // `motionplus.nunchuk` (Nunchuk options): a Nunchuk in the MotionPlus's port.
      const inPort = motionplus.nunchuk && new Nunchuk(this.board, { motion: scriptedMotion(), ...motionplus.nunchuk, attach: false });
      this.motionplus = new MotionPlus(this.board, { ...motionplus, nunchuk: inPort || null });
      this.nunchukInPort = inPort || null;
    } else {
      this.nunchuk = new Nunchuk(this.board, { motion: scriptedMotion(), ...nunchuk });
    }
    this.remote = new WiiRemote(this.board, { motionplus: !!motionplus, ...remote });
    this.remote.start();
    this.usb = new UsbCdcHost(this.board);
    this.pty = new PtyBridge(this.usb, link);
    this.wiicalPath = wiical;
    this.link = link;
  }

  /**
   * Runs `wiical device <args> --port <pty>` against the running firmware; resolves to
   * { code, stdout, stderr }. The board runs (emulated time) until the program exits or
   * `wallMs` of real time pass.
   */
  async wiical(args, { wallMs = 60000, onStdout = null } = {}) {
    await this.pty.open();
    const child = spawn(this.wiicalPath, ['device', ...args, '--port', this.link], { stdio: ['ignore', 'pipe', 'pipe'] });
    let stdout = '';
    let stderr = '';
    child.stdout.on('data', (d) => {
      stdout += d;
      onStdout?.(String(d), child);
    });
    child.stderr.on('data', (d) => (stderr += d));
    let code = null;
    child.on('exit', (c, sig) => (code = c ?? sig));
    const deadline = Date.now() + wallMs;
    while (code === null && Date.now() < deadline && !this.board.stopped) {
      await this.board.run(1);
    }
    if (code === null) {
      child.kill();
      code = 'timeout';
    }
    // Let the exit flush its last output.
    await new Promise((r) => setTimeout(r, 20));
    this.pty.close();
    return { code, stdout, stderr };
  }

  close() {
    this.pty.close();
    this.remote.stop();
  }
}
