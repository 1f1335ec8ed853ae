// A TRC marker file (Motion Analysis / OpenSim) read in the browser, the way the baker reads
// one (baker/src/io/capture/trc.rs): header values found by their key on line 2, marker names
// on line 4, one cell triple per marker on every data line, a blank or NaN cell missing, and
// positions converted to metres with the baker's factors (`Units::to_metres`).

const TO_METRES = { mm: 0.001, cm: 0.01, m: 1.0, in: 0.0254 };

function cells(line) {
  return line.includes('\t') ? line.split('\t').map((c) => c.trim()) : line.trim().split(/\s+/);
}

/**
 * Parse TRC text into { rate, names, frames } where `frames[f][m]` is [x, y, z] in metres or
 * null when missing. Throws an Error naming the line on malformed input.
 */
export function parseTrc(text) {
  const lines = text.split(/\r?\n/);
  if (!/^pathfiletype/i.test(lines[0] ?? '')) {
    throw new Error('not a TRC file: expected a PathFileType line');
  }
  const keys = cells(lines[1] ?? '');
  const values = cells(lines[2] ?? '');
  const value = (key) => {
    const i = keys.findIndex((k) => k.toLowerCase() === key.toLowerCase());
    if (i < 0 || values[i] === undefined) {
      throw new Error(`line 2: no ${key} in the TRC header`);
    }
    return values[i];
  };
  const rate = Number(value('DataRate'));
  const units = value('Units').toLowerCase();
  const scale = TO_METRES[units];
  if (!(rate > 0) || scale === undefined) {
    throw new Error(`line 3: bad DataRate ${value('DataRate')} or Units ${value('Units')}`);
  }
  const nameCells = cells(lines[3] ?? '');
  const names = [];
  for (let i = 2; i < nameCells.length; i += 3) {
    if (nameCells[i] !== '') {
      names.push(nameCells[i]);
    }
  }
  const frames = [];
  for (let n = 5; n < lines.length; n++) {
    if (lines[n].trim() === '') {
      continue;
    }
    const row = cells(lines[n]);
    if (row.length < 2 + 3 * names.length) {
      throw new Error(`line ${n + 1}: ${row.length} cells, ${2 + 3 * names.length} expected`);
    }
    const frame = [];
    for (let m = 0; m < names.length; m++) {
      const p = [0, 1, 2].map((c) => {
        const s = row[2 + 3 * m + c];
        return s === '' ? NaN : Number(s) * scale;
      });
      frame.push(p.every(Number.isFinite) ? p : null);
    }
    frames.push(frame);
  }
  return { rate, names, frames };
}
