// Starts `stlc lsp` (the language server of the stlc package) for .stl files.
const vscode = require("vscode");
const { LanguageClient } = require("vscode-languageclient/node");

let client;

function activate(context) {
  const [command, ...args] = vscode.workspace.getConfiguration("stlc").get("command");
  client = new LanguageClient("stlc", "stlc", { command, args },
    { documentSelector: [{ scheme: "file", language: "stlc" }] });
  context.subscriptions.push({ dispose: () => client && client.stop() });
  return client.start();
}

function deactivate() {
  return client ? client.stop() : undefined;
}

module.exports = { activate, deactivate };
