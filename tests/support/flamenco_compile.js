// A small stand-in for Flamenco Manager's job-compiler globals (as its job-type docs describe
// them: JOB_TYPE, compileJob(job), author.Task(name, type), task.addCommand, author.Command(
// name, parameters), job.addTask, print), to compile a job type with node and print the job.
// As strict as the Manager (internal/manager/job_compilers: goja.Compile(..., strict=true);
// Compile copies the submitted settings into the job and fills in no defaults): the script
// runs in strict mode and job.settings is exactly SETTINGS_JSON.
//   node flamenco_compile.js JOB_TYPE_SCRIPT SETTINGS_JSON
// Prints {"job_type": ..., "tasks": [{name, type, commands: [{name, parameters}]}]} or, when the
// script throws, {"error": message} (Flamenco shows a thrown string to the submitter).
const fs = require("fs");
const vm = require("vm");

const [script, settingsJson] = process.argv.slice(2);
const tasks = [];
const author = {
  Task(name, type) {
    const task = { name, type, commands: [], dependencies: [] };
    return {
      _task: task,
      addCommand(cmd) { task.commands.push(cmd); },
      addDependency(other) { task.dependencies.push(other._task.name); },
    };
  },
  Command(name, parameters) { return { name, parameters }; },
};
const job = {
  name: "test job",
  settings: JSON.parse(settingsJson),
  metadata: {},
  addTask(t) { tasks.push(t._task); },
};
const context = vm.createContext({ author, print: console.error, alert: console.error });
try {
  vm.runInContext('"use strict";\n' + fs.readFileSync(script, "utf8") +
                  "\nthis.JOB_TYPE = JOB_TYPE;", context, { filename: script });
  context.compileJob(job);
  console.log(JSON.stringify({ job_type: context.JOB_TYPE, tasks }));
} catch (err) {
  console.log(JSON.stringify({ error: String(err) }));
}
