// Copyright 2026 formation_control developers
//
// Licensed under the Apache License, Version 2.0 (the "License");
// you may not use this file except in compliance with the License.
// You may obtain a copy of the License at
//
//     http://www.apache.org/licenses/LICENSE-2.0
//
// Unless required by applicable law or agreed to in writing, software
// distributed under the License is distributed on an "AS IS" BASIS,
// WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
// See the License for the specific language governing permissions and
// limitations under the License.

// Mounts the Studio app of the UMD bundle (its exports are globals of the page).

class MemoryConfiguration {
  constructor(values) { this.values = new Map(Object.entries(values)); this.listeners = new Map(); }
  get(key) { return this.values.get(key); }
  async set(key, value) {
    this.values.set(key, value);
    for (const cb of this.listeners.get(key) ?? []) { cb(value); }
  }
  addChangeListener(key, cb) { this.listeners.set(key, [...(this.listeners.get(key) ?? []), cb]); }
  removeChangeListener(key, cb) {
    this.listeners.set(key, (this.listeners.get(key) ?? []).filter((f) => f !== cb));
  }
}

class MemoryLayouts {
  constructor() { this.byNamespace = new Map(); }
  spaces(namespace) {
    if (!this.byNamespace.has(namespace)) { this.byNamespace.set(namespace, new Map()); }
    return this.byNamespace.get(namespace);
  }
  async list(namespace) { return [...this.spaces(namespace).values()]; }
  async get(namespace, id) { return this.spaces(namespace).get(id); }
  async put(namespace, layout) { this.spaces(namespace).set(layout.id, layout); return layout; }
  async delete(namespace, id) { this.spaces(namespace).delete(id); }
  async importLayouts() {}
}

async function main() {
  const params = new URL(window.location.href).searchParams;
  const layouts = new MemoryLayouts();
  const data = await (await fetch(params.get('layout'))).json();
  await layouts.put('local', {
    id: params.get('layoutId'), name: params.get('layoutId'), permission: 'CREATOR_WRITE',
    baseline: { data, savedAt: new Date().toISOString() }, working: undefined,
    syncInfo: undefined,
  });
  await initI18n();
  const app = React.createElement(App, {
    deepLinks: [window.location.href],
    appConfiguration: new MemoryConfiguration({ 'telemetry.telemetryEnabled': false,
                                                'telemetry.crashReportingEnabled': false }),
    dataSources: [new FoxgloveWebSocketDataSourceFactory()],
    layoutStorage: layouts,
    extensionLoaders: [],
    enableGlobalCss: true,
  });
  ReactDOM.render(app, document.getElementById('root'));
}

main().catch((err) => { document.body.dataset.hostError = String(err); throw err; });
