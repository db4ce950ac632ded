// The WebSocket of a session: MOVEs out as JSON text frames, solved positions back as TMF1
// binary frames (service/api/stream.py). Latest MOVE wins on the server. The stream asks for
// boundary-first frames: each MOVE's boundary positions as soon as the boundary system is solved
// (header.frame "boundary", the boundary vertices in ascending order), then its full frame.
import { decodeFrame } from "./binary.js";

export class Stream {
  /**
   * @param {string} sessionId
   * @param {string} key API key ("" for none)
   * @param {{onFrame: Function, onMessage: Function, onClose: Function}} handlers
   *   onFrame({header, data}) for each solved MOVE, onMessage(doc) for text frames (errors),
   *   onClose() when the socket closes by itself.
   */
  constructor(sessionId, key, { onFrame, onMessage, onClose }) {
    const proto = location.protocol === "https:" ? "wss" : "ws";
    const q = `kind=positions&dtype=float32&frames=boundary${key ? `&api_key=${encodeURIComponent(key)}` : ""}`;
    this.ws = new WebSocket(`${proto}://${location.host}/v1/sessions/${sessionId}/stream?${q}`);
    this.ws.binaryType = "arraybuffer";
    this.ws.onmessage = (ev) => {
      if (typeof ev.data === "string") onMessage(JSON.parse(ev.data));
      else onFrame(decodeFrame(ev.data));
    };
    this.ws.onclose = () => onClose();
    this.queue = [];  // messages sent while the socket connects
    this.ws.onopen = () => {
      for (const text of this.queue) this.ws.send(text);
      this.queue = [];
    };
  }

  get open() { return this.ws.readyState === WebSocket.OPEN; }
  get usable() { return this.ws.readyState <= WebSocket.OPEN; }

  /** Send one message (queued while the socket connects); false when it is closing or closed. */
  send(doc) {
    if (!this.usable) return false;
    const text = JSON.stringify(doc);
    if (this.open) this.ws.send(text); else this.queue.push(text);
    return true;
  }

  close() {
    this.ws.onclose = null;
    this.ws.close();
  }
}
