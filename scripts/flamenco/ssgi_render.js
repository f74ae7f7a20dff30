// SPDX-License-Identifier: GPL-3.0-or-later
//
// Flamenco job type: SSGI frames rendered by Blender on the workers, through the extension's farm_render.py.
// Install: copy this file into the Manager's `scripts` folder and restart the Manager. Define the two-way variable
// `ssgi_farm_script` in flamenco-manager.yaml as the path of farm_render.py in the workers' installed SSGI extension
// (e.g. <Blender user folder>/extensions/user_default/ssgi/farm_render.py), per platform.
// Each task runs: blender -b FILE --render-output OUT --render-format FMT --python-exit-code 1 --python SCRIPT -- --frames CHUNK
// Chunks rendered by different workers equal one machine's run (the temporal mode renders the frames a chunk's first
// frames blend with); a task fails when Blender exits non-zero (a frame not written, a scene SSGI cannot render).

const JOB_TYPE = {
  label: "SSGI Render",
  settings: [
    { key: "frames", type: "string", required: true,
      eval: "f'{C.scene.frame_start}-{C.scene.frame_end}'",
      evalInfo: { showLinkButton: true, description: "Scene frame range" },
      description: "Frames to render, e.g. '1-48' or '1-10, 20'" },
    { key: "chunk_size", type: "int32", default: 8, visible: "submission",
      description: "Frames per task; with the temporal mode each task also renders up to two frames before its chunk" },
    { key: "render_output_root", type: "string", subtype: "dir_path", required: true, visible: "submission",
      description: "Folder the frames go into (a job-named folder is made inside)" },
    { key: "render_output_path", type: "string", subtype: "file_path", editable: false,
      eval: "str(Path(abspath(settings.render_output_root), jobname, '######'))",
      description: "Where the frames are written" },
    { key: "ssgi_script", type: "string", required: true, default: "{ssgi_farm_script}", visible: "submission",
      description: "farm_render.py of the SSGI extension installed on the workers" },
    { key: "blendfile", type: "string", required: true, visible: "web", description: "The .blend to render" },
    { key: "format", type: "string", required: true, eval: "C.scene.render.image_settings.file_format", visible: "web" },
  ],
};

const videoFormats = ["FFMPEG", "AVI_RAW", "AVI_JPEG"];

function compileJob(job) {
  const settings = job.settings;
  if (videoFormats.indexOf(settings.format) >= 0) {
    throw `SSGI renders image files, not "${settings.format}": choose an image format in Output Properties`;
  }
  const output = settings.render_output_path;
  for (const chunk of frameChunker(settings.frames, settings.chunk_size)) {
    const task = author.Task(`ssgi-${chunk}`, "blender");
    task.addCommand(author.Command("blender-render", {
      exe: "{blender}",
      exeArgs: "{blenderArgs}",
      argsBefore: [],
      blendfile: settings.blendfile,
      args: [
        "--render-output", output,
        "--render-format", settings.format,
        "--python-exit-code", "1",
        "--python", settings.ssgi_script,
        "--", "--frames", chunk,
      ],
    }));
    job.addTask(task);
  }
}
