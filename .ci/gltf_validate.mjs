// Runs the Khronos glTF Validator (npm package `gltf-validator`) over .glb files and fails
// unless every one has 0 errors and 0 warnings; infos and hints are printed, not failed.
// Usage: node gltf_validate.mjs VALIDATOR_DIR FILE.glb...
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";

const [validatorDir, ...files] = process.argv.slice(2);
const validator = createRequire(validatorDir + "/")("gltf-validator");
let failed = 0;
for (const file of files) {
  const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
    maxIssues: 0,
  });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  const bad = numErrors + numWarnings > 0;
  failed += bad ? 1 : 0;
  console.log(
    `${bad ? "FAIL" : "ok  "} ${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos, ${numHints} hints (validator ${report.validatorVersion})`,
  );
  for (const m of messages) {
    const severity = ["error", "warning", "info", "hint"][m.severity];
    console.log(`      ${severity} ${m.code} at ${m.pointer ?? "-"}: ${m.message}`);
  }
}
process.exit(failed > 0 ? 1 : 0);
