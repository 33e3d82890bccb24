// Run a Python script on MicroPython's WebAssembly port with a staged /lib.
// usage: node fw_mpy_run.mjs MICROPYTHON_MJS STAGE_DIR SCRIPT.py
import fs from "node:fs";
import path from "node:path";
import { pathToFileURL } from "node:url";

const [mjs, stage, script] = process.argv.slice(2);
const { loadMicroPython } = await import(pathToFileURL(mjs).href);
const mp = await loadMicroPython({
  heapsize: 16 * 1024 * 1024,
  stdout: (line) => process.stdout.write(line + "\n"),
  stderr: (line) => process.stderr.write(line + "\n"),
  linebuffer: true,
});

function copy(src, dst) {
  for (const name of fs.readdirSync(src)) {
    const s = path.join(src, name);
    const d = dst + "/" + name;
    if (fs.statSync(s).isDirectory()) {
      mp.FS.mkdir(d);
      copy(s, d);
    } else {
      mp.FS.writeFile(d, fs.readFileSync(s));
    }
  }
}
mp.FS.mkdir("/lib");
copy(stage, "/lib");
try {
  mp.runPython("import sys\nsys.path.insert(0, '/lib')\n" + fs.readFileSync(script, "utf8"));
} catch (err) {
  process.stderr.write(String(err) + "\n");
  process.exit(1);
}
