// Build the browser editor into ../service/static/editor: our sources as they are, plus the
// three.js modules they import (from node_modules, pinned by package-lock.json). No bundler:
// the page loads ES modules through an import map, and nothing comes from a CDN.
import { cpSync, mkdirSync, rmSync, writeFileSync, readFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const out = join(here, "..", "service", "static", "editor");
const three = join(here, "node_modules", "three");

rmSync(out, { recursive: true, force: true });
mkdirSync(join(out, "vendor", "addons", "controls"), { recursive: true });
cpSync(join(here, "src"), out, { recursive: true });
for (const f of ["three.module.js", "three.core.js"]) {
  cpSync(join(three, "build", f), join(out, "vendor", f));
}
for (const f of ["OrbitControls.js", "TransformControls.js"]) {
  cpSync(join(three, "examples", "jsm", "controls", f), join(out, "vendor", "addons", "controls", f));
}
cpSync(join(three, "LICENSE"), join(out, "vendor", "THREE-LICENSE.txt"));
const version = JSON.parse(readFileSync(join(three, "package.json"), "utf8")).version;
writeFileSync(join(out, ".built"), `three ${version}\n`);
console.log(`editor built into ${out} (three ${version})`);
