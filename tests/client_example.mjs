// node tests/client_example.mjs [ws://127.0.0.1:7681/]
import WebSocket from 'ws'; // Node 20 has no global WebSocket (a browser passes none)
import { connect } from '../web/client.js';

const c = await connect(process.argv[2] ?? 'ws://127.0.0.1:7681/', { WebSocket });
console.log(`hello: ${c.hello.server} ${c.hello.version}, groom ${c.hello.groom.strands} x ${c.hello.groom.verts}`);

const ok = await c.request({ type: 'set_params', values: { gravity: 4.9 } });
console.log(`gravity 4.9 from step ${ok.step}`);
try {
  await c.request({ type: 'set_params', values: { gravity: -1 } });
} catch (e) {
  console.log(`refused: ${e.code} ${e.field}`); // out_of_range values.gravity
}

const groom = await c.groomData();
console.log(`rest length of strand 0: ${groom.restLengths[0].toFixed(4)} m`);

for await (const { header, positions } of c.frames()) {
  if (header.simStep < ok.step) continue; // frames before the change
  console.log(`step ${header.simStep}: ${positions.length / 3} vertices, tip of strand 0 at y = ${positions[3 * (header.nverts - 1) + 1].toFixed(4)} m`);
  break;
}
c.close();
