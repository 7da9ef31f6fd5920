// Validates Kubernetes manifests (multi-document YAML) against the Kubernetes API's JSON schema,
// offline: kubernetes-models carries the schemas of the API's objects (generated from the
// Kubernetes OpenAPI specification) and validates with Ajv. Used by tests/cluster_test.cpp on
// the manifests `lensim dispatch --engine kubernetes` writes.
//   node validate.mjs FILE.yaml   -> exit 0 and "N objects valid", or exit 1 with the errors
import { readFileSync } from "node:fs";
import { parseAllDocuments } from "yaml";
import * as batchV1 from "kubernetes-models/batch/v1";
import * as coreV1 from "kubernetes-models/v1";

const models = { "batch/v1": batchV1, v1: coreV1 };
const file = process.argv[2];
if (!file) {
  console.error("usage: node validate.mjs FILE.yaml");
  process.exit(2);
}
let failures = 0, count = 0;
for (const doc of parseAllDocuments(readFileSync(file, "utf8"))) {
  if (doc.errors.length) {
    console.error(`${file}: YAML error: ${doc.errors[0].message}`);
    failures++;
    continue;
  }
  const obj = doc.toJS();
  if (obj === null) continue;
  count++;
  const Model = models[obj.apiVersion]?.[obj.kind];
  if (!Model) {
    console.error(`${file}: unknown apiVersion/kind ${obj.apiVersion} ${obj.kind}`);
    failures++;
    continue;
  }
  try {
    new Model(obj).validate();
  } catch (e) {
    console.error(`${file}: ${obj.kind} ${obj.metadata?.name}: ${e.message}`);
    failures++;
  }
}
if (failures) process.exit(1);
console.log(`${file}: ${count} objects valid`);
