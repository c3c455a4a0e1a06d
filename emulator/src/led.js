// The status LED (GP25) as a person watching it would see it: the firmware's `led_task`
// (firmware/src/status.rs) sets the LED once per 100 ms slot from a 10-slot (1 s) pattern, so
// the LED's history, cut into 100 ms slots, is a string of '1' (lit) and '0' (dark) in time
// order. The string is built from the pin's edges (each run between two edges rounded to
// whole slots), which keeps it in step with the firmware's slot grid however long it runs.
//
// The self-calibration patterns of firmware/README.md, written slot 0 first (the firmware's
// bit masks read from bit 0), and what the harness looks for in the slot string:
//   arming (C + Z held)          1100110011   /11001100/
//   hold still, new orientation  1010000000   /0{6}101/
//   pose taken (1 s steady)      1111111111   a run of 8..13 lit slots
//   move to a new orientation    1010101010   /1010101/
//   done, then calibrated steady 0111111111   /101{25}/ (one dark slot, then steady for good)
//   failed                       1110111000   /01110111/

const SLOT_NS = 100e6;
const LED_GPIO = 25;

export const LED = {
  arming: /11001100/,
  waiting: /0{6}101/,
  move: /1010101/,
  done: /101{25}/,
  failed: /01110111/,
};

export class LedWatcher {
  constructor(board) {
    this.board = board;
    const pin = board.rp2040.gpio[LED_GPIO];
    this.pin = pin;
    /** Edges: { tNs, lit } in time order. */
    this.edges = [];
    pin.addListener(() => {
      const lit = Boolean(pin.outputEnable && pin.outputValue);
      const last = this.edges[this.edges.length - 1];
      if (!last || last.lit !== lit) this.edges.push({ tNs: board.nanos, lit });
    });
  }

  /**
   * The slot string from `fromNs` (emulated time) to now. The run in progress counts only its
   * completed slots.
   */
  slots(fromNs = 0) {
    let out = '';
    const now = this.board.nanos;
    for (let i = 0; i < this.edges.length; i++) {
      const { tNs, lit } = this.edges[i];
      const end = i + 1 < this.edges.length ? this.edges[i + 1].tNs : now;
      if (end <= fromNs) continue;
      const start = Math.max(tNs, fromNs);
      const n = i + 1 < this.edges.length ? Math.round((end - start) / SLOT_NS) : Math.floor((end - start) / SLOT_NS);
      out += (lit ? '1' : '0').repeat(Math.max(0, n));
    }
    return out;
  }

  /** Whether `pattern` (one of {@link LED}) shows in the slots since `fromNs`. */
  shows(pattern, fromNs = 0) {
    return pattern.test(this.slots(fromNs));
  }

  /** Runs of lit slots that look like "pose taken" (8..13 slots, bounded by dark slots). */
  poseTakenRuns(fromNs = 0) {
    const s = this.slots(fromNs);
    return (s.match(/0(1{8,13})(?=0)/g) || []).length;
  }

  /** Episodes of the "move to a new orientation" blink (a maximal alternating run counts once). */
  moveBlinks(fromNs = 0) {
    return (this.slots(fromNs).match(/(?:10){3,}1/g) || []).length;
  }
}
