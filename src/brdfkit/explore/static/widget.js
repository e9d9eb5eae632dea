// The notebook widget's glue (anywidget): appended to explorer.js by brdfkit.explore.widget, so
// that the widget ships as one ES module. Messages go through the widget's comm.
function render({ model, el }) {
  const handlers = [];
  model.on("msg:custom", (message, buffers) => { for (const h of handlers) h(message, buffers.map((b) => new Uint8Array(b.buffer, b.byteOffset, b.byteLength))); });
  const transport = { send: (message) => model.send(message), onMessage: (h) => handlers.push(h) };
  const config = JSON.parse(model.get("config"));
  const api = createExplorer(el, transport, config);
  api.onFrame(() => { model.set("state", JSON.stringify(api.persistent())); model.save_changes(); });
  el.explorer = api;
}
export default { render };
