// Build the browser editor into ../service/static/editor: our sources as they are, plus the
// three.js modules they import (from node_modules, pinned by package-lock.json). No bundler:
// the page loads ES modules through an import map, and nothing comes from a CDN.
// Every module of src/ is copied; the build fails when a relative import names a file that is
// not there or a three.js addon is imported that is not vendored below.
import { cpSync, existsSync, mkdirSync, readdirSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { dirname, join, normalize } from "node:path";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const src = join(here, "src");
const out = join(here, "..", "service", "static", "editor");
const three = join(here, "node_modules", "three");
const ADDONS = ["controls/OrbitControls.js", "controls/TransformControls.js"];

// check the import graph before writing anything
const problems = [];
for (const f of readdirSync(src).filter((n) => n.endsWith(".js"))) {
  const text = readFileSync(join(src, f), "utf8");
  for (const m of text.matchAll(/^\s*import\s[^"']*["']([^"']+)["']/gm)) {
    const spec = m[1];
    if (spec.startsWith("./")) {
      if (!existsSync(normalize(join(src, spec)))) problems.push(`${f}: ${spec} does not exist`);
    } else if (spec.startsWith("three/addons/")) {
      if (!ADDONS.includes(spec.slice("three/addons/".length))) problems.push(`${f}: ${spec} is not vendored`);
    } else if (spec !== "three") {
      problems.push(`${f}: ${spec} is neither a local module nor three`);
    }
  }
}
const html = readFileSync(join(src, "index.html"), "utf8");
for (const m of html.matchAll(/\/editor\/([\w.-]+\.(?:js|css))/g)) {
  if (!existsSync(join(src, m[1]))) problems.push(`index.html: /editor/${m[1]} does not exist`);
}
if (problems.length) {
  console.error(`editor build failed:\n  ${problems.join("\n  ")}`);
  process.exit(1);
}

rmSync(out, { recursive: true, force: true });
mkdirSync(join(out, "vendor", "addons", "controls"), { recursive: true });
cpSync(src, out, { recursive: true });
for (const f of ["three.module.js", "three.core.js"]) {
  cpSync(join(three, "build", f), join(out, "vendor", f));
}
for (const f of ADDONS) {
  cpSync(join(three, "examples", "jsm", f), join(out, "vendor", "addons", f));
}
cpSync(join(three, "LICENSE"), join(out, "vendor", "THREE-LICENSE.txt"));
const version = JSON.parse(readFileSync(join(three, "package.json"), "utf8")).version;
writeFileSync(join(out, ".built"), `three ${version}\n`);
console.log(`editor built into ${out} (three ${version}, ${readdirSync(src).length} source files)`);
