// The WebSocket of a session: MOVEs out as JSON text frames, solved positions back as TMF1
// binary frames (service/api/stream.py). Latest MOVE wins on the server. The stream asks for
// boundary-first frames: each MOVE's boundary positions as soon as the boundary system is solved
// (header.frame "boundary", the boundary vertices in ascending order), then its full frame.
// A socket that drops (the service restarts, the network goes) is opened again by itself, after
// 0.5 s, 1 s, 2 s ... up to 10 s between tries; MOVEs sent meanwhile wait, the latest one winning,
// and go out when it is back, as does a MOVE that was out when it dropped. Closes that say the
// session cannot be streamed (unknown key or session, expired, refused) end it for good.
import { decodeFrame } from "./binary.js";

/** Close codes after which trying again cannot help (service/api/stream.py). */
const FINAL = new Set([4401, 4403, 4404, 4410, 1009]);
const BACKOFF_MS = [500, 1000, 2000, 4000, 8000, 10000];

export class Stream {
  /**
   * @param {string} sessionId
   * @param {string} key API key ("" for none)
   * @param {{onFrame: Function, onMessage: Function, onClose: Function, onState: Function}} handlers
   *   onFrame({header, data}) for each solved MOVE, onMessage(doc) for text frames (errors),
   *   onClose(event) when the stream has ended for good, onState(what, info) when it drops
   *   ("reconnecting", {attempt, delayMs, code}) and when it is back ("reconnected", {attempts}).
   */
  constructor(sessionId, key, { onFrame, onMessage, onClose, onState = () => {} }) {
    const proto = location.protocol === "https:" ? "wss" : "ws";
    const q = `kind=positions&dtype=float32&frames=boundary${key ? `&api_key=${encodeURIComponent(key)}` : ""}`;
    this.url = `${proto}://${location.host}/v1/sessions/${sessionId}/stream?${q}`;
    this.handlers = { onFrame, onMessage, onClose, onState };
    this.waiting = null;   // the latest MOVE sent while the socket is not open (latest wins)
    this.out = null;       // the last MOVE sent on an open socket and not answered yet: {seq, text}
    this.attempt = 0;      // tries since the socket last dropped
    this.ended = false;    // closed for good (by close() or a final code)
    this.timer = null;
    this.connect();
  }

  connect() {
    const ws = new WebSocket(this.url);
    ws.binaryType = "arraybuffer";
    ws.onmessage = (ev) => {
      if (typeof ev.data === "string") {
        const doc = JSON.parse(ev.data);
        this.answered(doc.seq);
        this.handlers.onMessage(doc);
      } else {
        const f = decodeFrame(ev.data);
        if (f.header.frame !== "boundary") this.answered(f.header.seq);
        this.handlers.onFrame(f);
      }
    };
    ws.onopen = () => {
      const back = this.attempt > 0;
      this.attempt = 0;
      // what was out when the socket dropped, unless a newer MOVE waits
      const text = this.waiting ?? (back && this.out ? this.out.text : null);
      this.waiting = null;
      if (text !== null) this.put(text);
      if (back) this.handlers.onState("reconnected", {});
    };
    ws.onclose = (ev) => this.dropped(ev);
    this.ws = ws;
  }

  dropped(ev) {
    if (this.ended) return;
    if (FINAL.has(ev.code)) {
      this.ended = true;
      this.handlers.onClose(ev);
      return;
    }
    const delayMs = BACKOFF_MS[Math.min(this.attempt, BACKOFF_MS.length - 1)];
    this.attempt += 1;
    this.handlers.onState("reconnecting", { attempt: this.attempt, delayMs, code: ev.code });
    this.timer = setTimeout(() => { this.timer = null; if (!this.ended) this.connect(); }, delayMs);
  }

  answered(seq) {
    if (this.out && seq !== null && seq !== undefined && seq >= this.out.seq) this.out = null;
  }

  put(text) {
    this.out = { seq: JSON.parse(text).seq, text };
    this.ws.send(text);
  }

  get open() { return !this.ended && this.ws.readyState === WebSocket.OPEN; }
  /** True while MOVEs can be sent: open, connecting, or waiting to connect again. */
  get usable() { return !this.ended; }
  /** True while the socket is down and being opened again. */
  get reconnecting() { return !this.ended && this.attempt > 0; }
  get readyState() { return this.ws.readyState; }

  /** Send one message (kept, latest wins, while the socket is not open); false when the stream has ended. */
  send(doc) {
    if (this.ended) return false;
    const text = JSON.stringify(doc);
    if (this.open) this.put(text); else this.waiting = text;
    return true;
  }

  close() {
    this.ended = true;
    clearTimeout(this.timer);
    this.ws.onclose = null;
    this.ws.onmessage = null;  // frames still on the way belong to no session shown
    this.ws.close();
  }
}
