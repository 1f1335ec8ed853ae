// Validates .glb files with the Khronos glTF validator (npm `gltf-validator`): prints each
// file's counts and every error and warning, and exits 1 if any file has one.
// Usage: node gltf-validate.cjs VALIDATOR_DIR FILE.glb...
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require(path.join(process.argv[2], 'node_modules', 'gltf-validator'));

async function main(files) {
  let failed = 0;
  for (const file of files) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      maxIssues: 0,
      // External resources are refused: the GLBs embed everything.
      externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
    });
    const n = report.issues;
    const bad = n.numErrors + n.numWarnings;
    console.log(`${file}: ${n.numErrors} errors, ${n.numWarnings} warnings, ${n.numInfos} infos, ` +
      `${n.numHints} hints (${report.info.animationCount} animations, ` +
      `morph targets: ${report.info.hasMorphTargets})`);
    for (const m of n.messages) {
      if (m.severity <= 1) console.log(`  ${m.severity === 0 ? 'ERROR' : 'WARNING'} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
    }
    if (bad > 0) failed += 1;
  }
  if (files.length === 0) {
    console.log('no .glb files given');
    process.exit(1);
  }
  process.exit(failed > 0 ? 1 : 0);
}

main(process.argv.slice(3)).catch((e) => {
  console.error(e);
  process.exit(1);
});
