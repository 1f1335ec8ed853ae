// Marker captures read in the browser the way the baker reads them (baker/src/io/capture/):
// TRC (Motion Analysis / OpenSim) and the baker's plain CSV, positions converted to metres with
// the baker's factors (`Units::to_metres`), a blank or NaN cell missing, a sample with any
// coordinate missing a missing sample. Each parser returns { rate, names, frames } where
// `frames[f][m]` is [x, y, z] in metres or null; malformed input throws an Error naming the line.

const TO_METRES = { mm: 0.001, cm: 0.01, m: 1.0, in: 0.0254 };
const UNIT_NAMES = {
  millimetre: 'mm', millimetres: 'mm', millimeter: 'mm', millimeters: 'mm',
  centimetre: 'cm', centimetres: 'cm', centimeter: 'cm', centimeters: 'cm',
  metre: 'm', metres: 'm', meter: 'm', meters: 'm',
  inch: 'in', inches: 'in',
};

/** The metres per unit of a units name (`mm`, `cm`, `m`, `in` or a long name), or undefined. */
function metresPer(units) {
  const u = units.trim().toLowerCase();
  return TO_METRES[UNIT_NAMES[u] ?? u];
}

/** A coordinate cell: a number, or NaN when blank or `NaN` (missing). */
function coordinate(cell, where) {
  if (cell === '' || cell.toLowerCase() === 'nan') {
    return NaN;
  }
  const x = Number(cell);
  if (!Number.isFinite(x)) {
    throw new Error(`${where}: "${cell}" is not a number`);
  }
  return x;
}

function cells(line) {
  return line.includes('\t') ? line.split('\t').map((c) => c.trim()) : line.trim().split(/\s+/);
}

/** A TRC file: header values by their key on line 2, names on line 4, a cell triple per marker. */
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
  const scale = metresPer(value('Units'));
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
        return coordinate(row[2 + 3 * m + c], `line ${n + 1}`) * scale;
      });
      frame.push(p.every(Number.isFinite) ? p : null);
    }
    frames.push(frame);
  }
  return { rate, names, frames };
}

/**
 * A CSV capture: `# rate=` and `# units=` comment lines, a header row of `frame`, `time` and
 * `Name_x,Name_y,Name_z` columns, one row per frame. Without `# rate=`, the rate comes from the
 * time column, (frames − 1) / (last time − first time).
 */
export function parseCsv(text) {
  const lines = text
    .split(/\r?\n/)
    .map((l, i) => [i + 1, l.trim()])
    .filter(([, l]) => l !== '');
  let rate = null;
  let scale;
  let at = 0;
  for (; at < lines.length && lines[at][1].startsWith('#'); at++) {
    const [key, value] = lines[at][1].slice(1).split('=');
    if (value === undefined) {
      continue;
    }
    if (key.trim().toLowerCase() === 'rate') {
      rate = Number(value);
    } else if (key.trim().toLowerCase() === 'units') {
      scale = metresPer(value);
    }
  }
  if (at === lines.length) {
    throw new Error('the file ends before the CSV header row');
  }
  if (scale === undefined) {
    throw new Error("no (known) '# units=' line: units are not guessed");
  }
  const header = lines[at][1].split(',').map((c) => c.trim());
  const names = [];
  const columns = header.map((cell, c) => {
    const lower = cell.toLowerCase();
    if (lower === 'frame' || lower === 'time') {
      return lower;
    }
    const axis = ['_x', '_y', '_z'].indexOf(lower.slice(-2));
    const name = cell.slice(0, -2);
    if (axis < 0 || (axis === 0 ? names.includes(name) : names[names.length - 1] !== name)) {
      throw new Error(`line ${lines[at][0]}, column ${c + 1}: "${cell}" is no frame, time or Name_x/_y/_z column in order`);
    }
    if (axis === 0) {
      names.push(name);
    }
    return 3 * (names.length - 1) + axis;
  });
  if (columns.filter((c) => typeof c === 'number').length !== 3 * names.length) {
    throw new Error(`line ${lines[at][0]}: a marker lacks its _y or _z column`);
  }
  const frames = [];
  const times = [];
  for (const [n, line] of lines.slice(at + 1)) {
    const cells = line.split(',').map((c) => c.trim());
    if (cells.length !== columns.length) {
      throw new Error(`line ${n}: ${cells.length} cells, ${columns.length} expected`);
    }
    const values = new Array(3 * names.length);
    cells.forEach((cell, c) => {
      const x = coordinate(cell, `line ${n}, column ${c + 1}`);
      if (columns[c] === 'time') {
        times.push(x);
      } else if (typeof columns[c] === 'number') {
        values[columns[c]] = x * scale;
      }
    });
    frames.push(names.map((_, m) => {
      const p = values.slice(3 * m, 3 * m + 3);
      return p.every(Number.isFinite) ? p : null;
    }));
  }
  if (rate === null && times.length > 1 && times[times.length - 1] !== times[0]) {
    rate = (frames.length - 1) / (times[times.length - 1] - times[0]);
  }
  if (!(rate > 0)) {
    throw new Error("no '# rate=' line and no time column to derive the rate from");
  }
  return { rate, names, frames };
}

/** A capture by its content: a TRC starts with PathFileType, anything else is read as CSV. */
export function parseCapture(text) {
  return /^\s*pathfiletype/i.test(text) ? parseTrc(text) : parseCsv(text);
}
