// ESLint for the editor's sources (make lint). The recommended rules, plus the ones that catch
// what a plain-module editor gets wrong most: unused names, shadowed globals, loose equality,
// reassigned constants, and browser globals used without being declared.
import js from "@eslint/js";
import globals from "globals";

// The state (src/state.js) is read-only outside its owners' writers: no assignment to a field of
// `state`, no mutating call on one, and `claim` of a group only in the module that owns it.
const MUTATORS = "/^(push|pop|shift|unshift|splice|sort|reverse|fill|copyWithin|set)$/";
const READ_ONLY = "the state is read-only: call the method of the module that owns the field (state.js)";
const stateRules = [
  { selector: "AssignmentExpression > MemberExpression.left[object.name='state']", message: READ_ONLY },
  { selector: "AssignmentExpression > MemberExpression.left[object.object.name='state']", message: READ_ONLY },
  { selector: "UpdateExpression > MemberExpression[object.name='state']", message: READ_ONLY },
  { selector: "UpdateExpression > MemberExpression[object.object.name='state']", message: READ_ONLY },
  { selector: "UnaryExpression[operator='delete'] > MemberExpression[object.name='state']", message: READ_ONLY },
  { selector: `CallExpression > MemberExpression.callee[object.object.name='state'][property.name=${MUTATORS}]`,
    message: READ_ONLY },
];
// the owner of each state group
const OWNERS = { "src/mesh.js": "mesh", "src/selection.js": "selection", "src/gizmo.js": "moves",
  "src/session.js": "session", "src/meshview.js": "view", "src/panels.js": "feedback", "src/shapes.js": "shapes" };
const claimOnly = (group) => ({
  selector: `CallExpression[callee.name='claim']${group ? `:not([arguments.0.value='${group}'])` : ""}`,
  message: group ? `this module owns the state group "${group}" only` : "only the owner of a state group claims it",
});

export default [
  js.configs.recommended,
  {
    files: ["src/**/*.js"],
    languageOptions: {
      ecmaVersion: 2022,
      sourceType: "module",
      globals: { ...globals.browser },
    },
    rules: {
      "no-unused-vars": ["error", { args: "after-used", argsIgnorePattern: "^_", caughtErrors: "none" }],
      eqeqeq: ["error", "smart"],
      "no-shadow": ["error", { builtinGlobals: false }],
      "no-var": "error",
      "prefer-const": "error",
      "no-implicit-globals": "error",
      "no-restricted-globals": ["error", "event", "name", "length", "status"],
      "no-restricted-syntax": ["error", ...stateRules, claimOnly(null)],
    },
  },
  ...Object.entries(OWNERS).map(([file, group]) => ({
    files: [file],
    rules: { "no-restricted-syntax": ["error", ...stateRules, claimOnly(group)] },
  })),
  {
    files: ["src/state.js"],
    rules: { "no-restricted-syntax": ["error", ...stateRules] },
  },
  {
    files: ["build.mjs", "eslint.config.js"],
    languageOptions: { ecmaVersion: 2022, sourceType: "module", globals: { ...globals.node } },
  },
];
