//! A seeded mutation harness for the `imap` command's inputs: 4 000 cases, each a small
//! valid scene (OBJ, MTL, TOML, an IES and a EULUMDAT file) with one to three mutations — bytes flipped, inserted
//! (control characters, invalid UTF-8), deleted or truncated; lines swapped, duplicated or
//! dropped; numbers replaced by hostile values; hostile statements and settings inserted.
//!
//! Every case must end in bounded time with status 0 (and every output complete) or 2
//! (one or more `imap: error:` lines, no raw control bytes, no output written); never a
//! panic (101), an abort or a signal. Set IMAP_MUTATION_CASES to run more or fewer.

use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a>(&mut self, v: &[&'a str]) -> &'a str {
        v[self.below(v.len())]
    }
}

const OBJ: &str = "# a floor, a lamp and a box\nmtllib s.mtl\no floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\no lamp\nusemtl lamp\nv 0.4 0.4 1\nv 0.6 0.4 1\nv 0.6 0.6 1\nv 0.4 0.6 1\nf 5 7 6\nf -4 -1 -2\ng box\nusemtl red\nv 0.2 0.2 0\nv 0.3 0.2 0\nv 0.3 0.3 0\nv 0.2 0.3 0\nv 0.2 0.2 0.1\nv 0.3 0.2 0.1\nv 0.3 0.3 0.1\nv 0.2 0.3 0.1\nf 9 10 14 13\nf 10 11 15 14\nf 11 12 16 15\nf 12 9 13 16\nf 13 14 15 16\ns off\nusemtl glass\nf 9 11 10\n";

const MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nKs 0.1\nNs 10\nillum 2\nnewmtl lamp\nKe 20 20 20\nnewmtl red\nKd 0.63 0.065 0.05\nd 1\nnewmtl glass\nKd 0 0 0\nNi 1.5\nd 0.1\nTf 0.9 0.9 0.9\n";

const IES: &str = "IESNA:LM-63-2002\n[TEST] mutation\nTILT=NONE\n1 -1 1 4 2 1 2 -0.1 0 0\n1 1 10\n0 30 60 90\n0 180\n500 400 200 0\n500 300 100 0\n";

const LDT: &str = "mutation\n1\n2\n4\n90\n3\n45\nr\nl\nn\nf\nd\n0\n0\n0\n100\n50\n0\n0\n0\n0\n100\n80\n1\n0\n1\n1\nLED\n1000\n3000K\n80\n10\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n90\n180\n270\n0\n45\n90\n300\n200\n0\n310\n190\n0\n320\n180\n0\n";

const TOML: &str = "unit_m = 1.0\nrecord = [\"floor\", \"box\"]\ntwo_sided = false\n[run]\nphotons = 300\ntime_s = 5\ntarget_error = 0.0\nthreads = 2\nscheduler = \"dynamic\"\nseed = 3\nprogress_interval_s = 0.1\n[[light]]\nkind = \"spot\"\nposition = [0.5, 0.5, 2]\ndirection = [0, 0, -1]\nhalf_angle_deg = 40\npower = 5\n[[light]]\nkind = \"cosine\"\nposition = [0.5, 0.5, 1.5]\ndirection = [0, 0, -1]\namount = 100\nunit = \"cd\"\nspectrum = \"3000K\"\n[[luminaire]]\nfile = \"l.ies\"\nposition = [0.3, 0.5, 1.8]\nuse_opening = true\n[[luminaire]]\nfile = \"l.ldt\"\npositions = [[0.7, 0.5, 1.8]]\nrotation_deg = 30\n[materials.red]\nspecular = 0.2\n[camera]\nposition = [0.5, -1, 1.5]\nlook_at = [0.5, 0.5, 0]\nfov_deg = 50\nwidth = 48\nheight = 40\n";

const HOSTILE_NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e39",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "-1",
    "99999999999999999999",
    "",
    "0x10",
    "1,5",
    "1.2.3",
    "é",
    "\u{202e}",
    "1e31",
    "3.4e38",
    "4294967296",
    "-4294967297",
    "1e300",
    "18446744073709551616",
];

const HOSTILE_OBJ_LINES: &[&str] = &[
    "f 1 2",
    "f 0 1 2",
    "f -100 1 2",
    "f 1/2/3/4 2 3",
    "f 1 1 1",
    "f a b c",
    "usemtl",
    "usemtl nowhere",
    "mtllib nofile.mtl",
    "mtllib",
    "v",
    "v 1 2",
    "vt",
    "vn 1",
    "o",
    "g",
    "l 1 2",
    "p 1",
    "f 1// 2// 3//",
    "f 1/99 2/1 3/1",
    "v 1e39 0 0",
    "v 1 2 3 4 5 6 7",
    "mtllib ../../../../etc/passwd",
    "f 2 3 4 5 6 7 8 9",
    "mtllib /dev/zero",
    "mtllib /dev/stdin",
    "mtllib /",
];

const HOSTILE_MTL_LINES: &[&str] = &[
    "Kd",
    "Kd 0.5",
    "Ke 10 2",
    "Ks 1 1 1",
    "Kd 2 2 2",
    "Kd -1 0 0",
    "d -1",
    "d 2",
    "Tr 5",
    "Ni 0",
    "Ni -3",
    "illum x",
    "newmtl",
    "map_Kd",
    "map_Kd -s 1 1 1",
    "map_Kd -o",
    "map_Kd nofile.png",
    "Kd spectral x.spd",
    "Kd xyz 1 1 1",
    "Tf 0 0 0",
    "Ke 1e308 1e308 1e308",
    "newmtl grey",
    "map_Kd /dev/zero",
    "map_Kd /",
];

const HOSTILE_TOML: &[&str] = &[
    "threads = 100000", "unit_m = 1e-300", "unit_m = 0", "unit_m = -1", "[spectral]\nbands = 0",
    "[spectral]\nbands = 100000", "[spectral]\nbands = 7\nmin_nm = 900\nmax_nm = 100",
    "record = [\"nope\"]", "two_sided = 3", "[[light]]\nkind = \"laser\"\nposition = [0, 0, 1]\npower = 1",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1e300]\npower = 1",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\npower = [1e308, 1e308, 1e308]",
    "[[light]]\nkind = \"spot\"\nposition = [0, 0, 1]\ndirection = [0, 0, 0]\nhalf_angle_deg = 0\npower = 1",
    "[materials.grey]\ndiffuse = [0.5, 0.5]", "[materials.glass]\ndielectric = false",
    "[materials.glass]\nior = 0.5", "[materials.glass]\nsellmeier = [[1, 1, 1], [1, 1, 1]]",
    "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, 0]", "[camera]\nwidth = 0",
    "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]",
    "[run]\nprogress_interval_s = 1e-12", "[run]\ntime_s = 1e300", "[run]\nscheduler = \"fast\"",
    "x = 1", "[run]\nthreads = -1", "[materials.nothing]\ndiffuse = 0.1",
    "[[light]]\nkind = \"beam\"\nposition = [0, 0, 1]\ndirection = [0, 0, -1]\namount = 1\nunit = \"lx\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 1\nunit = \"lx\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 10\nunit = \"parsec\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 10\nunit = \"lm\"\nspectrum = \"-5K\"",
    "[[light]]\nkind = \"point\"\nposition = [0, 0, 1]\namount = 10\nunit = \"lm\"\nspectrum_table = [[400, 0], [500, 0]]",
    "[[luminaire]]\nfile = \"nofile.ies\"\nposition = [0, 0, 1]",
    "[[luminaire]]\nfile = \"l.ies\"",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\naim = [0, 0, 0]",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\naim = [1, 0, 0]\nreference = [2, 0, 0]",
    "[[luminaire]]\nfile = \"l.ldt\"\narray = { start = [0, 0, 1], count = [1000000, 1000000], step_a = [1, 0, 0] }",
    "[[luminaire]]\nfile = \"l.ldt\"\narray = { start = [0, 0, 1], count = [30, 30], step_a = [0.01, 0, 0], step_b = [0, 0.01, 0] }",
    "[[luminaire]]\nfile = \"s.obj\"\nposition = [0, 0, 1]",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\nflux_scale = -1",
    "[[luminaire]]\nfile = \"l.ies\"\nposition = [0, 0, 1]\nlumens = 1e308",
    "[[luminaire]]\nfile = \"/dev/zero\"\nposition = [0, 0, 1]",
    "[environment]\nfile = \"/dev/zero\"\nscale = 1",
    "[environment]\nfile = \"/\"\nscale = 1",
    "[spectral]\nbands = 41\nmin_nm = 1\nmax_nm = 1e308",
    "[[grid]]\norigin = [0, 0, 0.1]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [1e300, 1e300]\nspacing = 1e-10",
    "[run]\ntime_s = -5",
    "portals = [\"floor\"]\n[sky]\nkind = \"uniform\"\nradiance = 1",
    "portals = [\"lamp\", \"box\", \"nope\"]",
    "glass_portals = true\n[sky]\nkind = \"cie\"\ncie_type = 12\nsun_azimuth_deg = 10\nsun_zenith_deg = 30\nradiance = 1",
    "glass_portals = true",
    "[sky]\nkind = \"uniform\"\nradiance = 1\nground_reflectance = 1e300",
    "[sky]\nkind = \"uniform\"\nradiance = 1e300\nground_reflectance = 1",
    "[[grid]]\npoints = \"/dev/zero\"",
    "[[grid]]\npoints = \"s.obj\"",
    "[[grid]]\npoints = \"s.mtl\"\nradius = -1",
    "[[grid]]\npoints = \"l.ies\"\norigin = [0, 0, 0]",
    "[camera]\nposition = [0.5, -1, 1.5]\nlook_at = [0.5, 0.5, 0]\nwidth = 4096\nheight = 16",
];

const RAD: &str = "# a room with a lamp and a window\nvoid plastic wall 0 0 5 .5 .5 .5 .02 .05\nvoid metal alu 0 0 5 .8 .8 .8 .9 0\nvoid trans opal 0 0 7 .6 .6 .6 0 0 1 .2\nvoid mirror m 0 0 3 .9 .9 .9\nvoid glass pane 0 0 3 .88 .88 .88\nvoid dielectric water 0 0 5 .9 .9 .9 1.33 0\nvoid light bulb 0 0 3 50 50 50\nvoid glow sky_glow 0 0 4 1 1 1 0\nvoid alias w2 wall\nvoid illum ill 1 wall 0 3 1 1 1\nvoid brightfunc dirt 2 d d.cal 0 0\ndirt plastic dm 0 0 5 .4 .4 .4 0 0\nwall polygon floor 0 0 12 0 0 0 4 0 0 4 4 0 0 4 0\nw2 polygon front 0 0 30 0 0 0 0 0 3 4 0 3 4 0 0 0 0 0 1 0 1 3 0 1 3 0 2 1 0 2 1 0 1\npane polygon window 0 0 12 1 0 1 3 0 1 3 0 2 1 0 2\nbulb sphere lamp 0 0 4 2 2 2.5 .1\nalu cylinder rod 0 0 7 2 2 2.6 2 2 3 .02\nopal ring shade 0 0 8 2 2 2.4 0 0 -1 0 .3\nm cone c 0 0 8 3 3 0 3 3 .5 .2 0\nwater bubble b 0 0 4 1 3 .3 .2\nill polygon port 0 0 9 0 4 1 0 4 2 0 3 2\ndm tube t 0 0 7 3 1 0 3 1 1 .1\nsky_glow cup cp 0 0 8 1 1 0 1 1 .2 .1 .2\n";

const HOSTILE_RAD: &[&str] = &[
    "!xform -t 1 0 0 chair.rad",
    "void plastic p 0 0 5 nan 1 1 0 0",
    "void light hot 0 0 3 1e308 1e308 1e308",
    "void glass g 0 0 3 inf 1 1",
    "wall sphere s 0 0 4 0 0 0 1e29",
    "wall sphere s0 0 0 4 0 0 0 0",
    "wall polygon q 0 0 999999999999999999999",
    "wall polygon huge 0 0 9 1e30 0 0 -1e30 0 0 0 1e30 0",
    "wall polygon line 0 0 9 0 0 0 1 0 0 2 0 0",
    "wall ring r 0 0 8 0 0 0 0 0 0 1 1",
    "wall cone k 0 0 8 0 0 0 0 0 0 1 1",
    "wall cylinder cy 0 0 7 0 0 0 0 0 1 -1",
    "void alias a missing",
    "wall mesh me 1 /dev/zero 0 0",
    "wall instance in 1 /dev/zero 0 0",
    "void light sun 0 0 3 1 1 1\nsun source so 0 0 4 0 0 1 .5",
    "void BSDF blind 6 0 /dev/zero 0 1 0 . 0 0",
    "undefined polygon u 0 0 9 0 0 0 1 0 0 0 1 0",
    "void plastic",
    "void plastic x -1",
    "void trans t 0 0 7 1 1 1 0 0 2 -5",
    "dirt polygon pat 0 0 9 0 0 0 1 0 0 0 1 0",
    "void illum i2 1 void 0 0",
    "i2 polygon gone 0 0 9 0 0 0 1 0 0 0 1 0",
];

fn mutate_bytes(rng: &mut Rng, text: &mut Vec<u8>) {
    if text.is_empty() {
        return;
    }
    let at = rng.below(text.len());
    match rng.below(5) {
        0 => text[at] ^= 1 << rng.below(8),
        1 => {
            let junk: &[&[u8]] = &[
                b"\x00",
                b"\x1b[2J",
                b"\xff\xfe",
                b"\r",
                b"\x07",
                b"\\\n",
                b"\t\t",
                b"\xc3",
            ];
            let j = junk[rng.below(junk.len())];
            text.splice(at..at, j.iter().copied());
        }
        2 => {
            let end = (at + 1 + rng.below(20)).min(text.len());
            text.drain(at..end);
        }
        3 => text.truncate(at),
        _ => {
            let end = (at + rng.below(8)).min(text.len());
            let copy: Vec<u8> = text[at..end].to_vec();
            text.splice(at..at, copy);
        }
    }
}

fn mutate_lines(rng: &mut Rng, text: &mut Vec<u8>, statements: &[&str]) {
    let s = String::from_utf8_lossy(text).into_owned();
    let mut lines: Vec<String> = s.lines().map(str::to_string).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let n = lines.len();
    match rng.below(6) {
        0 => {
            let (a, b) = (rng.below(n), rng.below(n));
            lines.swap(a, b);
        }
        1 => {
            let a = rng.below(n);
            lines.insert(a, lines[a].clone());
        }
        2 => {
            lines.remove(rng.below(n));
        }
        3 => {
            // A number replaced by a hostile one.
            let a = rng.below(n);
            let mut words: Vec<String> = lines[a].split(' ').map(str::to_string).collect();
            let nums: Vec<usize> = (0..words.len())
                .filter(|&i| words[i].parse::<f64>().is_ok() || words[i].contains('/'))
                .collect();
            if !nums.is_empty() {
                let i = nums[rng.below(nums.len())];
                words[i] = rng.pick(HOSTILE_NUMBERS).to_string();
                lines[a] = words.join(" ");
            }
        }
        4 => {
            let a = rng.below(n + 1);
            lines.insert(a, rng.pick(statements).to_string());
        }
        _ => {
            let a = rng.below(n);
            lines[a] = "9".repeat(1 + rng.below(100_000));
        }
    }
    *text = lines.join("\n").into_bytes();
    text.push(b'\n');
}

/// One case: the files, mutated; returns a description of a failure, if any.
fn case(seed: u64, dir: &Path) -> Result<(), String> {
    let mut rng = Rng(seed);
    let mut files = [
        OBJ.as_bytes().to_vec(),
        MTL.as_bytes().to_vec(),
        TOML.as_bytes().to_vec(),
        IES.as_bytes().to_vec(),
        LDT.as_bytes().to_vec(),
    ];
    for _ in 0..1 + rng.below(3) {
        let f = rng.below(5);
        match (f, rng.below(3)) {
            (_, 0) => mutate_bytes(&mut rng, &mut files[f]),
            (0, _) => mutate_lines(&mut rng, &mut files[0], HOSTILE_OBJ_LINES),
            (1, _) => mutate_lines(&mut rng, &mut files[1], HOSTILE_MTL_LINES),
            (3 | 4, _) => mutate_lines(&mut rng, &mut files[f], HOSTILE_NUMBERS),
            _ => {
                if rng.below(2) == 0 {
                    let extra = format!("\n{}\n", rng.pick(HOSTILE_TOML));
                    files[2].extend(extra.as_bytes());
                } else {
                    mutate_lines(&mut rng, &mut files[2], HOSTILE_NUMBERS);
                }
            }
        }
    }
    std::fs::create_dir_all(dir).unwrap();
    for (name, bytes) in ["s.obj", "s.mtl", "s.toml", "l.ies", "l.ldt"]
        .iter()
        .zip(&files)
    {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let out = dir.join("out");
    let _ = std::fs::remove_dir_all(&out);
    let t = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_imap"))
        .arg("run")
        .arg(dir.join("s.obj"))
        .arg("--config")
        .arg(dir.join("s.toml"))
        .args(["--photons", "300", "--time", "5", "--quiet", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            return Err(format!("seed {seed}: no exit within 60 s"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = Vec::new();
    use std::io::Read;
    child.stderr.take().unwrap().read_to_end(&mut err).unwrap();
    let err_text = String::from_utf8_lossy(&err).into_owned();
    let outputs: Vec<String> = std::fs::read_dir(&out)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    match status.code() {
        Some(0) => {
            let mut o = outputs.clone();
            o.sort();
            if o != [
                "convergence.png",
                "irradiance.csv",
                "irradiance.ply",
                "report.json",
                "view.png",
            ] {
                return Err(format!("seed {seed}: succeeded with outputs {o:?}"));
            }
            let report = std::fs::read_to_string(out.join("report.json")).unwrap();
            serde_json::from_str::<serde_json::Value>(&report)
                .map_err(|e| format!("seed {seed}: report.json: {e}"))?;
        }
        Some(2) => {
            let errors: Vec<&str> = err_text
                .lines()
                .filter(|l| l.starts_with("imap: error:"))
                .collect();
            if errors.is_empty() || errors.iter().any(|l| l.len() <= "imap: error: ".len()) {
                return Err(format!(
                    "seed {seed}: exit 2 without an error message: {err_text}"
                ));
            }
            if !outputs.is_empty() {
                return Err(format!(
                    "seed {seed}: failed but left outputs {outputs:?}: {err_text}"
                ));
            }
        }
        other => {
            return Err(format!(
                "seed {seed}: exit {other:?} (a panic or a signal): {err_text}"
            ))
        }
    }
    if err.iter().any(|&b| b < 0x20 && b != b'\n') {
        return Err(format!(
            "seed {seed}: raw control bytes on stderr: {err_text:?}"
        ));
    }
    Ok(())
}

/// Runs `imap` with `args` in bounded time; the case's failure, if it misbehaved: a panic,
/// a signal, a hang, an exit 2 without a message.
fn ends_in_a_status(seed: u64, args: &[&std::ffi::OsStr]) -> Result<i32, String> {
    use std::io::Read;
    let t = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_imap"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = stderr.read_to_end(&mut b);
        b
    });
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            return Err(format!("seed {seed}: {args:?}: no exit within 60 s"));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let err = String::from_utf8_lossy(&reader.join().unwrap()).into_owned();
    match status.code() {
        Some(0) => Ok(0),
        Some(2)
            if err
                .lines()
                .any(|l| l.len() > "imap: error: ".len() && l.starts_with("imap: error:")) =>
        {
            Ok(2)
        }
        other => Err(format!("seed {seed}: {args:?}: exit {other:?}: {err}")),
    }
}

/// A glTF 2.0 scene (a floor and a lamp above it) with its binary data: the JSON with the
/// buffer's URI left to the caller.
fn gltf_parts() -> (serde_json::Value, Vec<u8>) {
    let pos: [f32; 18] = [
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.3, 1.0, -0.3, 0.3, 1.0, -0.6, 0.6, 1.0,
        -0.3,
    ];
    let mut bin: Vec<u8> = pos.iter().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend([0u16, 1, 2, 0].iter().flat_map(|x| x.to_le_bytes()));
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0, "name": "floor", "children": [2]}, {"mesh": 1, "name": "lamp"}, {"name": "empty"}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 2, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 1}, "material": 1}]}
        ],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}},
            {"emissiveFactor": [1.0, 1.0, 1.0]}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, -1], "max": [1, 0, 0]},
            {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.3, 1, -0.6], "max": [0.6, 1, -0.3]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "bufferViews": [{"buffer": 0, "byteLength": 72}, {"buffer": 0, "byteOffset": 72, "byteLength": 6}],
        "buffers": [{"byteLength": 80}]
    });
    (json, bin)
}

/// A structural mutation of a glTF document: sizes, strides and counts past the data,
/// indices past their arrays, nodes shared or in cycles, URIs naming devices, numbers that
/// are no numbers.
fn mutate_gltf(rng: &mut Rng, v: &mut serde_json::Value) {
    let huge = [u32::MAX as u64, 1 << 40, 0, 1, 3, 7, 255, 1_000_000];
    let pick = |rng: &mut Rng| serde_json::json!(huge[rng.below(huge.len())]);
    match rng.below(12) {
        0 => v["accessors"][rng.below(3)]["count"] = pick(rng),
        1 => v["bufferViews"][rng.below(2)]["byteLength"] = pick(rng),
        2 => v["bufferViews"][0]["byteStride"] = serde_json::json!(4 * rng.below(64)),
        3 => v["buffers"][0]["byteLength"] = pick(rng),
        4 => v["accessors"][rng.below(3)]["byteOffset"] = pick(rng),
        5 => {
            let n = 2 + rng.below(70);
            let mut nodes: Vec<serde_json::Value> = (0..n)
                .map(|i| serde_json::json!({"children": [i + 1, i + 1]}))
                .collect();
            nodes.push(serde_json::json!({"mesh": 0}));
            nodes.push(serde_json::json!({"mesh": 1}));
            v["nodes"] = nodes.into();
            v["scenes"] = serde_json::json!([{"nodes": [0, n + 1]}]);
        }
        6 => v["nodes"][2]["children"] = serde_json::json!([0, 2]),
        7 => v["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = pick(rng),
        8 => v["meshes"][rng.below(2)]["primitives"][0]["indices"] = pick(rng),
        9 => {
            let dev = [
                "/dev/zero",
                "/dev/stdin",
                "/",
                "%2Fdev%2Fzero",
                "../../../../dev/zero",
            ];
            let d = dev[rng.below(dev.len())];
            if rng.below(2) == 0 {
                v["buffers"][0]["uri"] = d.into();
            } else {
                v["images"] = serde_json::json!([{"uri": d}]);
                v["textures"] = serde_json::json!([{"source": 0}]);
                v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] =
                    serde_json::json!({"index": 0});
            }
        }
        10 => {
            v["nodes"][0]["matrix"] =
                serde_json::json!([1e308, 0, 0, 0, 0, 1e308, 0, 0, 0, 0, 1e308, 0, 0, 0, 0, 1])
        }
        _ => v["materials"][1]["emissiveFactor"] = serde_json::json!([1e38, 3e38, 1e-45]),
    }
}

/// A model of another format than OBJ (glTF, GLB, PLY, STL), mutated; returns its file name.
fn model_case(rng: &mut Rng, dir: &Path) -> String {
    let (mut json, bin) = gltf_parts();
    match rng.below(7) {
        0 | 1 => {
            // glTF with its buffer beside it.
            std::fs::write(dir.join("m.bin"), &bin).unwrap();
            json["buffers"][0]["uri"] = "m.bin".into();
            for _ in 0..1 + rng.below(2) {
                mutate_gltf(rng, &mut json);
            }
            let mut text = serde_json::to_vec(&json).unwrap();
            if rng.below(3) == 0 {
                mutate_bytes(rng, &mut text);
            }
            std::fs::write(dir.join("m.gltf"), text).unwrap();
            "m.gltf".into()
        }
        2 => {
            // GLB: header, JSON chunk, BIN chunk; sizes in the headers mutated too.
            if rng.below(2) == 0 {
                mutate_gltf(rng, &mut json);
            }
            let mut j = serde_json::to_vec(&json).unwrap();
            while j.len() % 4 != 0 {
                j.push(b' ');
            }
            let mut b = bin.clone();
            while b.len() % 4 != 0 {
                b.push(0);
            }
            let total = 12 + 8 + j.len() + 8 + b.len();
            let mut glb = b"glTF".to_vec();
            glb.extend(2u32.to_le_bytes());
            glb.extend((total as u32).to_le_bytes());
            glb.extend((j.len() as u32).to_le_bytes());
            glb.extend(b"JSON");
            glb.extend(&j);
            glb.extend((b.len() as u32).to_le_bytes());
            glb.extend(b"BIN\0");
            glb.extend(&b);
            let fields = [8usize, 12, 20 + j.len()];
            match rng.below(4) {
                0 => {
                    let f = fields[rng.below(3)];
                    glb[f..f + 4]
                        .copy_from_slice(&[u32::MAX, 1 << 31, 0, 7][rng.below(4)].to_le_bytes());
                }
                1 => mutate_bytes(rng, &mut glb),
                _ => {}
            }
            std::fs::write(dir.join("m.glb"), glb).unwrap();
            "m.glb".into()
        }
        3 | 4 => {
            // PLY, ASCII or binary, with counts in the header past the data and numbers
            // that are no numbers.
            let binary = rng.below(2) == 0;
            let counts = [3u64, 4, 1 << 31, u32::MAX as u64, 0];
            let nv = if rng.below(3) == 0 {
                counts[rng.below(5)]
            } else {
                6
            };
            let nf = if rng.below(3) == 0 {
                counts[rng.below(5)]
            } else {
                2
            };
            let mut ply = format!(
                "ply\nformat {} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n",
                if binary { "binary_little_endian" } else { "ascii" }
            )
            .into_bytes();
            let mut p = [
                0.0f32, 0., 0., 1., 0., 0., 0., 1., 0., 0.3, 0.3, 1., 0.3, 0.6, 1., 0.6, 0.3, 1.,
            ];
            if rng.below(2) == 0 {
                p[rng.below(18)] = [f32::NAN, f32::INFINITY, -f32::INFINITY, 3e38][rng.below(4)];
            }
            if binary {
                ply.extend(p.iter().flat_map(|x| x.to_le_bytes()));
                for f in [[0i32, 1, 2], [3, 5, 4]] {
                    ply.push(3);
                    ply.extend(f.iter().flat_map(|x| x.to_le_bytes()));
                }
            } else {
                for v in p.chunks(3) {
                    ply.extend(format!("{} {} {}\n", v[0], v[1], v[2]).into_bytes());
                }
                ply.extend(b"3 0 1 2\n3 3 5 4\n");
            }
            if rng.below(3) == 0 {
                mutate_bytes(rng, &mut ply);
            }
            std::fs::write(dir.join("m.ply"), ply).unwrap();
            "m.ply".into()
        }
        5 => {
            // A Radiance scene: every primitive the reader knows, lines mutated and hostile
            // primitives inserted (counts past the file, numbers that are no numbers,
            // commands, devices, degenerate shapes).
            let mut text = RAD.as_bytes().to_vec();
            for _ in 0..1 + rng.below(3) {
                mutate_lines(rng, &mut text, HOSTILE_RAD);
            }
            if rng.below(3) == 0 {
                mutate_bytes(rng, &mut text);
            }
            std::fs::write(dir.join("m.rad"), text).unwrap();
            "m.rad".into()
        }
        _ => {
            // Binary STL with its triangle count past the data, or non-finite corners.
            let counts = [2u32, 1 << 31, u32::MAX, 0, 1000];
            let n = if rng.below(2) == 0 {
                counts[rng.below(5)]
            } else {
                2
            };
            let mut stl = vec![0u8; 80];
            stl.extend(n.to_le_bytes());
            let mut tri = |c: [[f32; 3]; 3]| {
                stl.extend([0f32; 3].iter().flat_map(|x| x.to_le_bytes()));
                for p in c {
                    stl.extend(p.iter().flat_map(|x| x.to_le_bytes()));
                }
                stl.extend([0u8, 0]);
            };
            let bad = [f32::NAN, f32::INFINITY, 1e30][rng.below(3)];
            tri([[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
            tri([
                [0.3, 0.3, 1.],
                [0.6, 0.3, 1.],
                [0.3, if rng.below(3) == 0 { bad } else { 0.6 }, 1.],
            ]);
            if rng.below(3) == 0 {
                mutate_bytes(rng, &mut stl);
            }
            std::fs::write(dir.join("m.stl"), stl).unwrap();
            "m.stl".into()
        }
    }
}

/// Models of every format other than OBJ, mutated in the classes an attack found: sizes in
/// headers past the file, shared and cyclic node graphs, URIs naming devices, numbers
/// that are no numbers. Each is read (`imap info`) and sometimes run; each must end in
/// a status (0, or 2 with a message) in bounded time, never a panic, an abort or a hang.
#[test]
fn mutated_models_of_every_format_end_in_a_status() {
    let cases: u64 = std::env::var("IMAP_MUTATION_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .map_or(1200, |n: u64| n / 3);
    let root = tempfile::tempdir().unwrap();
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .min(8);
    let t = Instant::now();
    std::thread::scope(|s| {
        for w in 0..workers {
            let (root, next, failures) = (&root, &next, &failures);
            s.spawn(move || {
                let dir = root.path().join(format!("m{w}"));
                std::fs::create_dir_all(&dir).unwrap();
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed) as u64;
                    if i >= cases {
                        break;
                    }
                    let seed = 50_000 + i;
                    let mut rng = Rng(seed);
                    let model = dir.join(model_case(&mut rng, &dir));
                    let r = ends_in_a_status(seed, &["info".as_ref(), model.as_os_str()]).and_then(
                        |code| {
                            if code != 0 || rng.below(4) != 0 {
                                return Ok(code);
                            }
                            let out = dir.join("out");
                            ends_in_a_status(
                                seed,
                                &[
                                    "run".as_ref(),
                                    model.as_os_str(),
                                    "--photons".as_ref(),
                                    "200".as_ref(),
                                    "--time".as_ref(),
                                    "5".as_ref(),
                                    "--quiet".as_ref(),
                                    "--out".as_ref(),
                                    out.as_os_str(),
                                ],
                            )
                        },
                    );
                    if let Err(e) = r {
                        failures.lock().unwrap().push(e);
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    eprintln!(
        "{cases} mutated glTF, GLB, PLY, Radiance and STL models in {:.0} s: {} misbehaved",
        t.elapsed().as_secs_f64(),
        failures.len()
    );
    for f in failures.iter().take(10) {
        eprintln!("  {f}");
    }
    assert!(failures.is_empty());
}

#[test]
fn mutated_inputs_end_in_a_status_never_a_crash() {
    let cases: u64 = std::env::var("IMAP_MUTATION_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4000);
    let root = tempfile::tempdir().unwrap();
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let (ok, err) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .min(8);
    let t = Instant::now();
    std::thread::scope(|s| {
        for w in 0..workers {
            let (root, next, failures, ok, err) = (&root, &next, &failures, &ok, &err);
            s.spawn(move || {
                let dir = root.path().join(format!("w{w}"));
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed) as u64;
                    if i >= cases {
                        break;
                    }
                    match case(1000 + i, &dir) {
                        Ok(()) => {
                            let code_ok = dir.join("out").join("report.json").exists();
                            if code_ok { ok } else { err }.fetch_add(1, Ordering::Relaxed);
                        }
                        Err(e) => failures.lock().unwrap().push(e),
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    eprintln!(
        "{cases} mutated inputs in {:.0} s: {} ran, {} were refused with a message, {} misbehaved",
        t.elapsed().as_secs_f64(),
        ok.load(Ordering::Relaxed),
        err.load(Ordering::Relaxed),
        failures.len()
    );
    for f in failures.iter().take(10) {
        eprintln!("  {f}");
    }
    assert!(failures.is_empty());
}
