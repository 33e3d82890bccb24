// An emulated Raspberry Pi Pico: the RP2040 of the npm package rp2040js, run by node for
// tactile_sim.emulator.pico_core, which owns everything outside the chip.
//
// Wiring only, no model: the boot ROM and the flash come from files; the chip's USB CDC and
// its two I2C controllers are bridged to the Python parent over three pipes:
//   fd 3 (to Python):   'U' USB bytes from the chip, 'A'/'W'/'R' I2C, 'T' time, 'X' reset,
//                        'C' USB configured, 'E' fatal, 'L' log line;
//   fd 4 (from Python): the answers to 'A' (1 byte) and 'R' (1 + READ_AHEAD bytes), read
//                        synchronously, so the chip stands still while Python answers;
//   fd 5 (from Python): 'H' bytes for the chip's USB OUT endpoint, 'P' hold/run, 'Q' quit.
// Each message: type (1 byte), payload length (u16 LE), payload.
//
// The ADS122C04s are Python's (the same models every core uses): an I2C transaction is
// asked for ('A': address phase at the chip's time), its written bytes sent ('W', at STOP)
// or, before its first read byte, sent with a request for the bytes a read returns ('R').
// A device cannot know how many bytes the controller will clock out, so the read's bytes
// are asked for once and handed out as the controller reads them. Each bus event completes
// after its bit times at the controller's own SCL period (hcnt + lcnt system clocks), so
// the bus costs the chip what it costs on a board.
//
// Flash: rp2040js reads flash but does not program it. The boot ROM's flash_range_erase
// ('RE') and flash_range_program ('RP') entries are replaced by BKPT; the break handler
// applies the operation to the flash array and to the flash file at once, then returns to
// LR. A watchdog reset (machine.reset()) restarts the chip on the same flash.
//
// Time: the chip's clock is rp2040js's simulation clock (125 MHz). While the core sleeps
// (WFE/WFI), or spins on a peripheral (the same load of the TIMER or an I2C controller again
// within SPIN_CYCLES: a busy-wait for the bus or for a deadline), its clock jumps to its next
// alarm (at most SPIN_MAX_NS ahead when spinning), as the instructions of the wait would have
// taken it there; a bus wait ends exactly when the byte completes, a deadline at most
// SPIN_MAX_NS late. Real time (default): only as far as the wall clock has gone, so an idle
// board costs no CPU and never runs ahead of real time. Fast: at once, and the chip holds
// while Python says 'P' 1 (no host, or the host is not reading). cfg.spin_skip false turns
// the spin rule off (benches that count cycles).

import fs from 'node:fs';
import net from 'node:net';
import { createRequire } from 'node:module';
import path from 'node:path';

const cfg = JSON.parse(process.argv[2]);
const require = createRequire(path.join(cfg.node_modules, 'noop.js'));
const { Simulator, ConsoleLogger, LogLevel, USBCDC } = require('rp2040js');
const { decodeBlock } = require('uf2');

const FLASH_SIZE = 2 * 1024 * 1024;
const FLASH_BASE = 0x10000000;
const READ_AHEAD = 16;
const BKPT_ERASE = 0xe1;
const BKPT_PROGRAM = 0xe2;
const OUT = 3;
const REPLY = 4;
const SLICE_MS = 10; // run this long between looks at the pipe from Python
const TIME_EVERY_NS = 1e6; // report the chip's time at least this often
const SPIN_CYCLES = 64; // a load repeated this soon from the same instruction: a busy-wait
const SPIN_MAX_NS = 20e3;
const TIMER_BASE = 0x40054;

// --- the pipes ----------------------------------------------------------------------------
function send(type, payload = Buffer.alloc(0)) {
  const head = Buffer.from([type.charCodeAt(0), payload.length & 0xff, payload.length >> 8]);
  fs.writeSync(OUT, Buffer.concat([head, payload]));
}

function readReply(n) {
  const buf = Buffer.alloc(n);
  let got = 0;
  while (got < n) {
    const k = fs.readSync(REPLY, buf, got, n - got, null);
    if (k === 0) process.exit(0); // Python has gone
    got += k;
  }
  return buf;
}

function timeBytes(nanos) {
  const b = Buffer.alloc(8);
  b.writeBigUInt64LE(BigInt(Math.round(nanos))); // the chip's time in ns
  return b;
}

// --- boot ROM and flash ---------------------------------------------------------------------
function patchedRom() {
  const rom = fs.readFileSync(cfg.bootrom);
  const table = rom.readUInt16LE(0x14);
  const entry = {};
  for (let p = table; rom.readUInt16LE(p) !== 0; p += 4) {
    const code = rom.readUInt16LE(p);
    entry[String.fromCharCode(code & 0xff, code >> 8)] = rom.readUInt16LE(p + 2) & ~1;
  }
  if (entry.RE === undefined || entry.RP === undefined) {
    throw new Error(`${cfg.bootrom}: no flash_range_erase/program in the ROM's function table`);
  }
  rom.writeUInt16LE(0xbe00 | BKPT_ERASE, entry.RE);
  rom.writeUInt16LE(0xbe00 | BKPT_PROGRAM, entry.RP);
  return new Uint32Array(rom.buffer.slice(rom.byteOffset, rom.byteOffset + rom.length));
}

function openFlash() {
  if (!fs.existsSync(cfg.flash)) {
    const image = new Uint8Array(FLASH_SIZE).fill(0xff);
    const uf2 = fs.readFileSync(cfg.image);
    for (let at = 0; at + 512 <= uf2.length; at += 512) {
      const block = decodeBlock(uf2.subarray(at, at + 512));
      image.set(block.payload, block.flashAddress - FLASH_BASE);
    }
    fs.writeFileSync(cfg.flash + '.tmp', image);
    fs.renameSync(cfg.flash + '.tmp', cfg.flash);
  }
  const fd = fs.openSync(cfg.flash, 'r+');
  const bytes = new Uint8Array(FLASH_SIZE);
  if (fs.readSync(fd, bytes, 0, FLASH_SIZE, 0) !== FLASH_SIZE) {
    throw new Error(`${cfg.flash}: not a 2 MB flash image`);
  }
  return { fd, bytes };
}

const ROM = patchedRom();
const FLASH = openFlash();

// --- the chip --------------------------------------------------------------------------------
let sim, mcu, cdc;
let resetPending = false;
let hold = cfg.fast; // fast: no host yet
let pendingOut = []; // the chip's armed USB OUT buffers, answered when the host has bytes
const hostBytes = [];
let lastTimeNs = -TIME_EVERY_NS;
let spinning = false;

function boot() {
  sim = new Simulator();
  mcu = sim.rp2040;
  mcu.logger = new ConsoleLogger(LogLevel.Error);
  mcu.loadBootrom(ROM);
  mcu.flash.set(FLASH.bytes);
  mcu.onBreak = onBreak;
  mcu.peripherals[0x40058].onWatchdogTrigger = () => { // (the watchdog is not a property)
    resetPending = true;
  };
  wireUsb();
  mcu.i2c.forEach(wireI2c);
  if (cfg.spin_skip !== false) {
    for (const p of [mcu.peripherals[TIMER_BASE], ...mcu.i2c]) watchSpin(p);
  }
  lastTimeNs = -TIME_EVERY_NS;
  mcu.core.PC = FLASH_BASE;
  pendingOut = [];
}

function onBreak(code) {
  const core = mcu.core;
  const r = core.registers;
  if (code === BKPT_ERASE) {
    const [at, n] = [r[0], r[1]];
    mcu.flash.fill(0xff, at, at + n);
    persist(at, n);
  } else if (code === BKPT_PROGRAM) {
    const [at, src, n] = [r[0], r[1], r[2]];
    for (let i = 0; i < n; i++) mcu.flash[at + i] &= mcu.readUint8(src + i);
    persist(at, n);
  } else {
    send('E', Buffer.from(`the chip stopped at a breakpoint (${code}) at ${(core.PC - 2).toString(16)}`));
    process.exit(3);
  }
  core.PC = r[14] & ~1; // return from the ROM routine
}

function persist(at, n) {
  FLASH.bytes.set(mcu.flash.subarray(at, at + n), at);
  fs.writeSync(FLASH.fd, mcu.flash, at, n, at);
}

function wireUsb() {
  cdc = new USBCDC(mcu.usbCtrl);
  cdc.onDeviceConnected = () => send('C');
  cdc.onSerialData = (data) => send('U', Buffer.from(data));
  // rp2040js answers every armed OUT buffer at once, empty when the host has nothing: the
  // chip then takes a USB interrupt every 10 us. A host answers when it has data.
  mcu.usbCtrl.onEndpointRead = (endpoint, size) => {
    if (endpoint !== cdc.outEndpoint) return;
    pendingOut.push(size);
    feedUsb();
  };
}

function feedUsb() {
  while (hostBytes.length && pendingOut.length) {
    const size = pendingOut.shift();
    const chunk = Uint8Array.from(hostBytes.splice(0, size));
    mcu.usbCtrl.endpointReadDone(cdc.outEndpoint, chunk);
  }
}

// A load from `peripheral` by the instruction that loaded from it SPIN_CYCLES ago or less
// (keyed by the instruction's address) marks a busy-wait: see "Time" above.
function watchSpin(peripheral) {
  const read = peripheral.readUint32.bind(peripheral);
  const last = new Map();
  peripheral.readUint32 = (offset) => {
    const core = mcu.core;
    const at = last.get(core.PC);
    if (at !== undefined && core.cycles - at <= SPIN_CYCLES) spinning = true;
    last.set(core.PC, core.cycles);
    return read(offset);
  };
}

// --- I2C: transactions answered by Python ------------------------------------------------------
function wireI2c(i2c, bus) {
  let txn = null;
  const bitNs = () => ((i2c.sclHighPeriod + i2c.sclLowPeriod) * 1e9) / mcu.clkSys;
  const later = (bits, done) => {
    if (!cfg.bus_time) return done();
    const alarm = mcu.clock.createAlarm(done);
    alarm.schedule(bits * bitNs());
  };
  const now = () => timeBytes(mcu.clock.nanos);
  const flushWrite = () => {
    if (txn && txn.ack && !txn.read && txn.written.length) {
      send('W', Buffer.concat([Buffer.from([bus, txn.addr]), now(), Buffer.from(txn.written)]));
    }
  };
  i2c.onStart = () => later(1, () => i2c.completeStart());
  i2c.onConnect = (addr, mode) => {
    if (!txn || addr !== txn.addr) {
      flushWrite();
      send('A', Buffer.concat([Buffer.from([bus, addr, mode]), now()]));
      txn = { addr, ack: readReply(1)[0] === 0, written: [], read: null, at: 0 };
    }
    const ack = txn.ack;
    later(9, () => i2c.completeConnect(ack));
  };
  i2c.onWriteByte = (value) => {
    txn.written.push(value);
    later(9, () => i2c.completeWrite(true));
  };
  i2c.onReadByte = () => {
    if (!txn.read) {
      send('R', Buffer.concat([Buffer.from([bus, txn.addr]), now(), Buffer.from(txn.written)]));
      const reply = readReply(1 + READ_AHEAD);
      txn.read = reply.subarray(1);
    }
    const value = txn.at < txn.read.length ? txn.read[txn.at] : 0xff;
    txn.at += 1;
    later(9, () => i2c.completeRead(value));
  };
  i2c.onStop = () => {
    flushWrite();
    txn = null;
    later(1, () => i2c.completeStop());
  };
}

// --- the pipe from Python ----------------------------------------------------------------------
let inbox = Buffer.alloc(0);
const input = new net.Socket({ fd: 5, readable: true, writable: false });
input.on('data', (chunk) => {
  inbox = Buffer.concat([inbox, chunk]);
  while (inbox.length >= 3) {
    const n = inbox.readUInt16LE(1);
    if (inbox.length < 3 + n) break;
    const type = String.fromCharCode(inbox[0]);
    const payload = inbox.subarray(3, 3 + n);
    inbox = inbox.subarray(3 + n);
    if (type === 'H') {
      for (const b of payload) hostBytes.push(b);
      feedUsb();
    } else if (type === 'P') {
      hold = payload[0] !== 0;
    } else if (type === 'Q') {
      process.exit(0);
    }
  }
});
input.on('end', () => process.exit(0));

// --- the run -----------------------------------------------------------------------------------
const wallStart = performance.now();
let simStart = 0;

function slice() {
  if (hold) return setTimeout(slice, 2);
  const core = mcu.core;
  const clock = mcu.clock;
  const cycleNs = 1e9 / mcu.clkSys;
  const end = performance.now() + SLICE_MS;
  let idleMs = 0;
  while (idleMs === 0 && performance.now() < end) {
    for (let i = 0; i < 2000; i++) {
      if (core.waiting || spinning) {
        let step = clock.nanosToNextAlarm;
        if (spinning) {
          spinning = false;
          step = step > 0 ? Math.min(step, SPIN_MAX_NS) : SPIN_MAX_NS;
        }
        if (!cfg.fast) {
          const ahead = clock.nanos - simStart - (performance.now() - wallStart) * 1e6;
          if (ahead >= 0) {
            idleMs = Math.min(5, Math.max(1, ahead / 1e6));
            break;
          }
          step = step > 0 ? Math.min(step, -ahead) : -ahead;
        }
        if (step <= 0) {
          idleMs = 1; // nothing scheduled: only the host can wake it
          break;
        }
        clock.tick(step);
      } else {
        clock.tick(core.executeInstruction() * cycleNs);
      }
      if (resetPending) break;
    }
    if (resetPending) {
      resetPending = false;
      simStart = -(performance.now() - wallStart) * 1e6; // the new chip's clock starts at 0
      boot();
      send('X');
      return setImmediate(slice);
    }
  }
  if (clock.nanos - lastTimeNs >= TIME_EVERY_NS) {
    lastTimeNs = clock.nanos;
    send('T', timeBytes(clock.nanos));
  }
  if (idleMs > 0) return setTimeout(slice, idleMs);
  setImmediate(slice);
}

process.on('uncaughtException', (err) => {
  try {
    send('E', Buffer.from(String(err && err.message ? err.message : err)));
  } finally {
    process.exit(3);
  }
});

boot();
slice();
