#!/usr/bin/env node
// Decodes a file of MAVLink frames (concatenated as captured from UDP datagrams) with
// node-mavlink, an implementation independent of ipsd's, and prints one JSON document:
//   {"packets": [{"magic", "msgid", "sysid", "compid", "seq", "payload_length", "name", "fields"}],
//    "crc_errors": N, "invalid": N}
// The splitter checks every frame's CRC-16/MCRF4XX with the CRC_EXTRA from its own message
// tables; a frame that fails is counted in crc_errors and not decoded. Non-finite floats are
// printed as the strings "NaN"/"Infinity" and 64-bit integers as decimal strings (JSON has neither).
'use strict';
const fs = require('fs');
const { Readable } = require('stream');
const { MavLinkPacketSplitter, MavLinkPacketParser, minimal, common } = require('node-mavlink');

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };

function plain(value) {
  if (typeof value === 'bigint') return value.toString();
  if (typeof value === 'number' && !Number.isFinite(value)) return String(value);
  if (Array.isArray(value)) return value.map(plain);
  return value;
}

function main() {
  if (process.argv.length !== 3) {
    process.stderr.write('usage: decode.js FRAMES_FILE\n');
    process.exit(2);
  }
  const bytes = fs.readFileSync(process.argv[2]);
  let crcErrors = 0;
  const splitter = new MavLinkPacketSplitter({}, { onCrcError: () => { crcErrors++; } });
  const packets = [];
  Readable.from([bytes]).pipe(splitter).pipe(new MavLinkPacketParser()).on('data', (packet) => {
    const entry = {
      magic: packet.header.magic,
      msgid: packet.header.msgid,
      sysid: packet.header.sysid,
      compid: packet.header.compid,
      seq: packet.header.seq,
      payload_length: packet.header.payloadLength,
    };
    const clazz = REGISTRY[packet.header.msgid];
    if (clazz) {
      entry.name = clazz.MSG_NAME;
      const data = packet.protocol.data(packet.payload, clazz);
      entry.fields = {};
      for (const field of clazz.FIELDS) entry.fields[field.source] = plain(data[field.name]);
    }
    packets.push(entry);
  }).on('end', () => {
    process.stdout.write(JSON.stringify({ packets, crc_errors: crcErrors, invalid: splitter.invalidPackages }) + '\n');
  });
}

main();
