// The Khronos glTF validator over the files named on the command line: one JSON line per file, in order,
// {"file": ..., "errors": ["CODE@/json/pointer", ...]} with the issues of severity Error, or {"file": ..., "rejected":
// "..."} when the validator cannot read the file as glTF or GLB at all. External resources (buffers, images)
// resolve against the file's directory, as the simulator's importer resolves them.
// Used by tests/sim/gltf_validator_oracle_test.cpp; scripts/setup.sh --with-gltf-validator installs the validator.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validate(file) {
  const data = fs.readFileSync(file);
  try {
    const report = await validator.validateBytes(new Uint8Array(data), {
      uri: path.basename(file),
      maxIssues: 0,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)),
                    (error, bytes) => (error ? reject(error.toString()) : resolve(bytes)));
      }),
    });
    const errors = report.issues.messages.filter((m) => m.severity === 0)
                       .map((m) => m.code + '@' + (m.pointer === undefined ? '' : m.pointer));
    return {file, errors};
  } catch (error) {
    return {file, rejected: String(error)};
  }
}

(async () => {
  for (const file of process.argv.slice(2)) process.stdout.write(JSON.stringify(await validate(file)) + '\n');
})();
