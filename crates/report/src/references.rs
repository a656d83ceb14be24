//! The sources the report cites, with authors, journal and year, so that a
//! reader can trace every criterion, threshold and convention. Bracketed
//! numbers are those of seed 001's reference list, as the criteria's
//! sources give them.

use std::fmt::Write as _;

/// One cited source: the label the page uses and the full reference.
pub struct Reference {
    pub label: &'static str,
    pub text: &'static str,
}

pub const REFERENCES: &[Reference] = &[
    Reference {
        label: "seed 000",
        text: "Geometric modeling of a reconstructed aortic valve closure (talk of the seeds' group; templates, spring model, closure benchmark after Marom et al. 2013).",
    },
    Reference {
        label: "seed 001",
        text: "Impact of material stiffness and anisotropy on coaptation characteristics for aortic valve cusps reconstructed from pericardium. MDPI, 2021 (CC BY 4.0): §1 the coaptation criteria, §2 the template, suturing and membrane models, §3 the GOH parameters of fixed pericardium.",
    },
    Reference {
        label: "seed 002",
        text: "Моделирование диастолического состояния клапана в задаче реконструкции аортального клапана по методу Озаки [Modelling the diastolic state of the valve for Ozaki aortic valve reconstruction] (talk of the seeds' group; effective height at 3 mmHg).",
    },
    Reference {
        label: "[13]",
        text: "Ozaki S, Kawase I, Yamashita H, Uchida S, Nozawa Y, Matsuyama T, Takatoh M, Hagiwara S. Aortic valve reconstruction using self-developed aortic valve plasty system in aortic valve disease. Interact Cardiovasc Thorac Surg. 2011;12:550–553.",
    },
    Reference {
        label: "[18]",
        text: "Muller WH Jr, Warren WD, Dammann JF Jr, Beckwith JR, Wood JE Jr. Surgical relief of aortic insufficiency by direct operation on the aortic valve. Circulation. 1960;21:587–597.",
    },
    Reference {
        label: "[19]",
        text: "Tada N, Tanaka N, Abe K, Hata M. Transcatheter aortic valve implantation after aortic valve neocuspidization using autologous pericardium: a case report. Eur Heart J Case Rep. 2019;3:ytz105.",
    },
    Reference {
        label: "[21]",
        text: "Le Polain de Waroux JB, Pouleur AC, Robert A, Pasquet A, Gerber BL, Noirhomme P, El Khoury G, Vanoverschelde JLJ. Mechanisms of recurrent aortic regurgitation after aortic valve repair: predictive value of intraoperative transesophageal echocardiography. JACC Cardiovasc Imaging. 2009;2:931–939.",
    },
    Reference {
        label: "[22]",
        text: "Kunihara T, Aicher D, Rodionycheva S, Groesdonk HV, Langer F, Sata F, Schäfers HJ. Preoperative aortic root geometry and postoperative cusp configuration primarily determine long-term outcome after valve-preserving aortic root repair. J Thorac Cardiovasc Surg. 2012;143:1389–1395.",
    },
    Reference {
        label: "[23]",
        text: "Miyahara S, Omura A, Sakamoto T, Nomura Y, Inoue T, Minami H, Okada K, Okita Y. Impact of postoperative cusp configuration on midterm durability after aortic root reimplantation. J Heart Valve Dis. 2013;22:509–516.",
    },
    Reference {
        label: "[24]",
        text: "Ridley C, Sohmer B, Vallabhajosyula P, Augoustides JGT. Aortic leaflet billowing as a risk factor for repair failure after aortic valve repair. J Cardiothorac Vasc Anesth. 2017;31:1001–1006.",
    },
    Reference {
        label: "[25]",
        text: "Schäfers HJ, Bierbach B, Aicher D. A new approach to the assessment of aortic cusp geometry. J Thorac Cardiovasc Surg. 2006;132:436–438.",
    },
    Reference {
        label: "Marom et al.",
        text: "Marom G, Haj-Ali R, Rosenfeld M, Schäfers HJ, Raanani E. Aortic root numeric model: annulus diameter prediction of effective height and coaptation in post-aortic valve repair. J Thorac Cardiovasc Surg. 2013;145:406–411.",
    },
    Reference {
        label: "ASE/EACVI",
        text: "Zoghbi WA, et al. Recommendations for noninvasive evaluation of native valvular regurgitation (American Society of Echocardiography, with the Society for Cardiovascular Magnetic Resonance). J Am Soc Echocardiogr. 2017;30:303–371. Lancellotti P, et al. Recommendations for the echocardiographic assessment of native valvular regurgitation (European Association of Cardiovascular Imaging). Eur Heart J Cardiovasc Imaging. 2013;14:611–644. Mild aortic regurgitation: effective regurgitant orifice area < 0.10 cm².",
    },
    Reference {
        label: "membrane_model",
        text: "The seeds' group's code, github.com/23Grammer58/membrane_model: AorticSimulator/Messurer (coaptation measures) and benchmarks/Sewing/ForOptimizerOneLeaf.h (optimal ranges, billowing < 1.4 mm).",
    },
    Reference {
        label: "SlicerHeart",
        text: "Lasso A, Herz C, Nam H, Cianciulli A, Pieper S, Drouin S, Pinter C, St-Onge S, Vigil C, Ching S, Sunderland K, Fichtinger G, Kikinis R, Jolley MA. SlicerHeart: an open-source computing platform for cardiac image analysis and modeling. Front Cardiovasc Med. 2022;9:886549.",
    },
    Reference {
        label: "GOH",
        text: "Gasser TC, Ogden RW, Holzapfel GA. Hyperelastic modelling of arterial layers with distributed collagen fibre orientations. J R Soc Interface. 2006;3:15–35.",
    },
];

/// The References section of the page.
pub fn section(h: &mut String) {
    h.push_str("<section id=\"references\">\n<h2>References</h2>\n");
    h.push_str("<p>Bracketed numbers are those of seed 001's reference list, which the criteria cite; the seeds are the source papers and talks coapt implements.</p>\n<ol class=\"references\">\n");
    for r in REFERENCES {
        let _ = writeln!(
            h,
            "<li><strong>{}</strong> {}</li>",
            super::html::esc(r.label),
            super::html::esc(r.text)
        );
    }
    h.push_str("</ol>\n</section>\n");
}

#[cfg(test)]
mod tests {
    #[test]
    fn labels_are_unique() {
        let mut l: Vec<&str> = super::REFERENCES.iter().map(|r| r.label).collect();
        l.sort_unstable();
        let n = l.len();
        l.dedup();
        assert_eq!(l.len(), n);
    }
}
