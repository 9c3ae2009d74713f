// A small plot of two series over the last frames: ms per step (left scale) and the engine's
// GI updates per second (right scale). `push` records, `draw` paints (the page paints a few
// times a second).

export class Plot {
  constructor(canvas, length = 300) {
    this.canvas = canvas;
    this.length = length;
    this.a = [];
    this.b = [];
  }

  push(a, b) {
    this.a.push(a);
    this.b.push(b);
    if (this.a.length > this.length) { this.a.shift(); this.b.shift(); }
  }

  draw() {
    const c = this.canvas, g = c.getContext('2d');
    const w = c.width, h = c.height;
    g.clearRect(0, 0, w, h);
    const series = (data, colour, side) => {
      const max = Math.max(1e-9, ...data) * 1.1;
      g.strokeStyle = colour;
      g.beginPath();
      data.forEach((v, i) => {
        const x = (i / (this.length - 1)) * w;
        const y = h - 4 - (v / max) * (h - 16);
        if (i === 0) g.moveTo(x, y); else g.lineTo(x, y);
      });
      g.stroke();
      g.fillStyle = colour;
      g.font = '10px sans-serif';
      g.textAlign = side;
      g.fillText(`max ${max.toFixed(max < 10 ? 1 : 0)}`, side === 'left' ? 2 : w - 2, 10);
    };
    series(this.a, '#6cf', 'left');
    series(this.b, '#fb5', 'right');
  }
}
