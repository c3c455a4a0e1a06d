// Bridges the emulated USB CDC function to a pseudo-terminal with socat (Debian's `socat`),
// so that the unmodified `wiical device …` opens it like /dev/ttyACM0. socat's standard input
// and output are the host side of the CDC pipe: bytes the program writes to the pty come out
// of socat's stdout and go to the adapter's bulk OUT endpoint; the adapter's bulk IN data goes
// to socat's stdin and so to the program.
//
// socat exits when the program closes the pty (EIO on the master), so every `open()` starts a
// fresh socat and waits for its link to appear.

import { spawn } from 'node:child_process';
import { existsSync, rmSync } from 'node:fs';

export class PtyBridge {
  constructor(usbHost, link) {
    this.usb = usbHost;
    this.link = link;
    this.proc = null;
    usbHost.onData = (bytes) => {
      if (this.proc && this.proc.stdin.writable) this.proc.stdin.write(Buffer.from(bytes));
    };
  }

  /** Starts socat; resolves when the link exists. */
  async open() {
    this.close();
    rmSync(this.link, { force: true });
    const proc = spawn('socat', ['-lf/dev/null', `PTY,link=${this.link},raw,echo=0,wait-slave`, 'STDIO'], {
      stdio: ['pipe', 'pipe', 'inherit'],
    });
    proc.stdin.on('error', () => {});
    proc.stdout.on('data', (chunk) => this.usb.write(chunk));
    proc.on('exit', () => {
      if (this.proc === proc) this.proc = null;
    });
    this.proc = proc;
    const deadline = Date.now() + 5000;
    while (!existsSync(this.link)) {
      if (Date.now() > deadline) throw new Error('socat did not create the pseudo-terminal');
      await new Promise((r) => setTimeout(r, 5));
    }
  }

  close() {
    if (this.proc) {
      this.proc.kill();
      this.proc = null;
    }
  }
}
