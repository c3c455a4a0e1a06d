// The USB host side of the adapter's CDC-ACM function, driven through rp2040js's device-mode
// USB controller hooks: bus reset, enumeration (SET_ADDRESS, configuration descriptor,
// SET_CONFIGURATION, SET_CONTROL_LINE_STATE with DTR), then bulk OUT (host → adapter) and bulk
// IN (adapter → host) transfers. Unlike a busy host, an OUT endpoint the firmware arms while
// the host has nothing to send is NAKed (left pending) until data arrives, so the firmware's
// executor can sleep.

import { createSetupPacket, setDeviceAddressPacket, getDescriptorPacket, setDeviceConfigurationPacket } from 'rp2040js';

const CONFIGURATION = 2;
const INTERFACE = 4;
const ENDPOINT = 5;
const CDC_DATA_CLASS = 0x0a;
const SET_CONTROL_LINE_STATE = 0x22;
const PACKET = 64;
// DPRAM buffer control (RP2040 datasheet 4.1.2.5): EPx_OUT_BUFFER_CONTROL at 0x84 + 8·x.
const EP0_OUT_BUFFER_CONTROL = 0x84;
const BUF_FULL = 1 << 15;
const BUF_AVAILABLE = 1 << 10;
const BUF_LEN_MASK = 0x3ff;

/** Bulk IN/OUT endpoint numbers of the CDC data interface in a configuration descriptor. */
export function cdcEndpoints(desc) {
  const out = { in: -1, out: -1 };
  let dataInterface = false;
  for (let i = 0; i + 1 < desc.length && desc[i] >= 2; i += desc[i]) {
    const [len, type] = [desc[i], desc[i + 1]];
    if (type === INTERFACE && len >= 9) dataInterface = desc[i + 5] === CDC_DATA_CLASS;
    if (dataInterface && type === ENDPOINT && len >= 7 && (desc[i + 3] & 3) === 2) {
      if (desc[i + 2] & 0x80) out.in = desc[i + 2] & 0x0f;
      else out.out = desc[i + 2] & 0x0f;
    }
  }
  return out;
}

export class UsbCdcHost {
  constructor(board) {
    this.board = board;
    const usb = board.rp2040.usbCtrl;
    this.usb = usb;
    this.toDevice = [];
    this.pendingOut = null; // requested length while the firmware waits for OUT data
    this.configured = false;
    this.endpoints = { in: -1, out: -1 };
    this.onData = null; // (Uint8Array) bytes from the adapter
    this.enumerations = 0;
    this.steps = [];
    this.descriptor = [];
    usb.onUSBEnabled = () => usb.resetDevice();
    usb.onResetReceived = () => this.enumerate();
    usb.onEndpointWrite = (ep, buffer) => this.endpointWrite(ep, buffer);
    usb.onEndpointRead = (ep, size) => this.endpointRead(ep, size);
  }

  /** Control transfers of the enumeration, one at a time. */
  enumerate() {
    this.configured = false;
    this.descriptor = [];
    this.descriptorLength = null;
    this.steps = [
      { setup: setDeviceAddressPacket(1), data: false },
      { setup: getDescriptorPacket(CONFIGURATION, 9), data: true, onData: (d) => { this.descriptorLength = d[2] | (d[3] << 8); } },
      { setup: () => getDescriptorPacket(CONFIGURATION, this.descriptorLength), data: true, onData: (d) => { this.endpoints = cdcEndpoints(d); } },
      { setup: setDeviceConfigurationPacket(1), data: false },
      {
        setup: createSetupPacket({ dataDirection: 0, type: 1, recipient: 1, bRequest: SET_CONTROL_LINE_STATE, wValue: 3, wIndex: 0, wLength: 0 }),
        data: false,
        done: () => {
          this.configured = true;
          this.enumerations += 1;
        },
      },
    ];
    this.nextStep();
  }

  nextStep() {
    this.step = this.steps.shift() ?? null;
    this.received = [];
    if (!this.step) return;
    const setup = typeof this.step.setup === 'function' ? this.step.setup() : this.step.setup;
    this.expected = setup[6] | (setup[7] << 8);
    this.usb.sendSetupPacket(setup);
  }

  endpointWrite(ep, buffer) {
    if (ep === 0) {
      if (!this.step) return;
      if (this.step.data) {
        this.received.push(...buffer);
        // The data stage ends with a short packet or when all requested bytes arrived; the
        // status stage (OUT ZLP) is answered in endpointRead.
        if (buffer.length < PACKET || this.received.length >= this.expected) {
          this.step.onData?.(this.received);
          this.step.data = false;
          this.step.awaitStatusOut = true;
          if (this.ep0OutArmed) this.statusOut();
        }
      } else if (buffer.length === 0) {
        // Status stage of a no-data request (IN ZLP).
        this.step.done?.();
        this.nextStep();
      }
      return;
    }
    if (ep === this.endpoints.in) this.onData?.(buffer);
  }

  endpointRead(ep, size) {
    if (ep === 0) {
      // The firmware arms EP0 OUT for the status stage of an IN request (possibly before the
      // data stage is over): answer with the zero-length packet once the data is in.
      this.ep0OutArmed = true;
      if (this.step?.awaitStatusOut) this.statusOut();
      return;
    }
    if (ep === this.endpoints.out) {
      // Until the host sends, the buffer stays AVAILABLE (the hardware NAKs the host): rp2040js
      // clears the bit as soon as the firmware arms the buffer, which the firmware would take
      // for a received packet.
      this.pendingOut = size;
      this.setOutControl(ep, (c) => c | BUF_AVAILABLE);
      this.flushOut();
    }
  }

  setOutControl(ep, change) {
    const view = this.board.rp2040.usbDPRAMView;
    const offset = EP0_OUT_BUFFER_CONTROL + ep * 8;
    view.setUint32(offset, change(view.getUint32(offset, true)) >>> 0, true);
  }

  statusOut() {
    this.ep0OutArmed = false;
    this.step.awaitStatusOut = false;
    this.usb.endpointReadDone(0, new Uint8Array(0));
    // Give the firmware's status-stage completion a moment before the next SETUP.
    this.board.clock.createAlarm(() => this.nextStep()).schedule(50e3);
  }

  flushOut() {
    if (this.pendingOut === null || !this.toDevice.length) return;
    const n = Math.min(this.pendingOut, PACKET, this.toDevice.length);
    const chunk = Uint8Array.from(this.toDevice.splice(0, n));
    this.pendingOut = null;
    const ep = this.endpoints.out;
    // Hand the packet over as the controller does: data into the buffer, then FULL with its
    // length and AVAILABLE cleared, then the BUFF_STATUS bit.
    this.board.rp2040.usbDPRAM.set(chunk, this.usb.getEndpointBufferOffset(ep, true));
    this.setOutControl(ep, (c) => ((c & ~BUF_AVAILABLE & ~BUF_LEN_MASK) | BUF_FULL | chunk.length));
    this.usb.indicateBufferReady(ep, true);
  }

  /** Bytes from the host application (the pseudo-terminal) to the adapter. */
  write(bytes) {
    for (const b of bytes) this.toDevice.push(b);
    this.flushOut();
  }

  /**
   * SET_CONTROL_LINE_STATE with DTR (and RTS) set or cleared, as a host's serial driver sends
   * when a process opens the port or the last one holding it closes it (a hang-up).
   * `lineStates` counts the requests completed.
   */
  setLineState(dtr) {
    this.lineStates ??= 0;
    this.steps = [{
      setup: createSetupPacket({ dataDirection: 0, type: 1, recipient: 1, bRequest: SET_CONTROL_LINE_STATE, wValue: dtr ? 3 : 0, wIndex: 0, wLength: 0 }),
      data: false,
      done: () => { this.lineStates += 1; },
    }];
    this.nextStep();
  }

  /** Unplug and replug: a bus reset, after which the host enumerates again. */
  busReset() {
    this.configured = false;
    this.pendingOut = null;
    this.toDevice = [];
    this.usb.resetDevice();
  }
}
