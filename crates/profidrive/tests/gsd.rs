//! The GSD file, parsed by an independent parser (gsd-parser), against what the slave accepts.

use dp_slave::Application;
use profidrive::ppo::Ppo;
use profidrive::prm::{OperationMode, UserPrm};
use profidrive::testing::MockDrive;
use profidrive::ProfidriveApp;

fn gsd_text() -> String {
    let mut text = String::new();
    profidrive::gsd::write(&mut text).unwrap();
    text
}

fn parsed() -> gsd_parser::GenericStationDescription {
    let text = gsd_text();
    gsd_parser::parser::parse(std::path::Path::new(profidrive::gsd::FILE_NAME), &text)
        .unwrap_or_else(|e| panic!("{e}\n{text}"))
}

#[test]
fn every_mandatory_dp_v0_keyword_is_there() {
    let text = gsd_text();
    let keywords = [
        "GSD_Revision",
        "Vendor_Name",
        "Model_Name",
        "Revision",
        "Ident_Number",
        "Protocol_Ident",
        "Station_Type",
        "FMS_supp",
        "Hardware_Release",
        "Software_Release",
        "9.6_supp",
        "19.2_supp",
        "45.45_supp",
        "93.75_supp",
        "187.5_supp",
        "500_supp",
        "1.5M_supp",
        "3M_supp",
        "6M_supp",
        "12M_supp",
        "MaxTsdr_9.6",
        "MaxTsdr_19.2",
        "MaxTsdr_45.45",
        "MaxTsdr_93.75",
        "MaxTsdr_187.5",
        "MaxTsdr_500",
        "MaxTsdr_1.5M",
        "MaxTsdr_3M",
        "MaxTsdr_6M",
        "MaxTsdr_12M",
        "Redundancy",
        "Repeater_Ctrl_Sig",
        "24V_Pins",
        "Min_Slave_Intervall",
        "Modular_Station",
        "Max_Module",
        "Max_Input_Len",
        "Max_Output_Len",
        "Max_Data_Len",
        "Max_Diag_Data_Len",
    ];
    for k in keywords {
        assert!(
            text.lines()
                .any(|l| l.split('=').next().is_some_and(|key| key.trim() == k)),
            "{k} missing"
        );
    }
}

#[test]
fn identity_rates_and_services() {
    let gsd = parsed();
    assert_eq!(gsd.ident_number, dp_consts::ADAPTER_IDENT_NUMBER);
    assert!(gsd.auto_baud_supported && gsd.set_slave_addr_supported && gsd.fail_safe);
    assert!(gsd.freeze_mode_supported && gsd.sync_mode_supported);
    use gsd_parser::SupportedSpeeds as S;
    let all = S::B9600
        | S::B19200
        | S::B45450
        | S::B93750
        | S::B187500
        | S::B500000
        | S::B1500000
        | S::B3000000
        | S::B6000000
        | S::B12000000;
    assert!(gsd.supported_speeds.contains(all));
    let t = &gsd.max_tsdr;
    let declared = [
        t.b9600,
        t.b19200,
        t.b45450,
        t.b93750,
        t.b187500,
        t.b500000,
        t.b1500000,
        t.b3000000,
        t.b6000000,
        t.b12000000,
    ];
    assert_eq!(
        declared, [15; 10],
        "the transceiver answers at min TSDR (11 bit times) at every rate: 15 declared"
    );
    // Never looser than a VPC3+-based slave (shared/reference/gsd/CP24V1.gsd, EASY4711.gsd).
    let vpc3 = [15, 15, 15, 15, 15, 15, 20, 35, 50, 95];
    assert!(
        declared.iter().zip(vpc3).all(|(d, v)| *d <= v),
        "{declared:?}"
    );
    assert_eq!(usize::from(gsd.max_diag_data_length), 8);
}

#[test]
fn each_module_is_a_configuration_chk_cfg_accepts() {
    let gsd = parsed();
    assert_eq!(gsd.available_modules.len(), 6);
    let mut app = ProfidriveApp::new(MockDrive::default());
    for (module, ppo) in gsd.available_modules.iter().zip(Ppo::ALL) {
        assert_eq!(module.name, format!("PPO Type {}", ppo.number()));
        assert_eq!(module.config, ppo.cfg());
        let io = app
            .accept_cfg(&module.config)
            .expect("Chk_Cfg accepts the module");
        assert_eq!(io.inputs, ppo.io_bytes());
        assert!(ppo.io_bytes() <= usize::from(gsd.max_input_length));
    }
}

#[test]
fn the_default_user_parameters_are_what_set_prm_accepts() {
    let gsd = parsed();
    let defaults = gsd_parser::PrmBuilder::new(&gsd.user_prm_data).into_bytes();
    assert_eq!(defaults, UserPrm::DEFAULT.encode());
    let mut app = ProfidriveApp::new(MockDrive::default());
    assert!(app.accept_user_prm(&defaults));
    // A tool's choice through the GSD's own fields parses as that choice.
    let mut builder = gsd_parser::PrmBuilder::new(&gsd.user_prm_data);
    builder.set_prm_from_text("Operation mode", "PROFIdrive (seed 004)");
    builder.set_prm("Cut-off time ms (0 = none)", 250);
    builder.set_prm("WrPZD3", 0xF105);
    let prm = UserPrm::parse(builder.as_bytes()).unwrap();
    assert_eq!(prm.operation, OperationMode::Profidrive);
    assert_eq!(prm.cut_off_ms, 250);
    assert_eq!(prm.wr_pzd[1].0, 0xF105);
    let mut builder = gsd_parser::PrmBuilder::new(&gsd.user_prm_data);
    builder.set_prm_from_text("Operation mode", "ABB Drives (+-20000)");
    assert_eq!(
        UserPrm::parse(builder.as_bytes()).unwrap().operation,
        OperationMode::AbbDrives
    );
}

fn dpv1_text() -> String {
    let mut text = String::new();
    profidrive::gsd::write_variant(&mut text, profidrive::gsd::Variant::DpV1).unwrap();
    text
}

/// Seed 004: "对于 DP-V1，必须使用 GSD 文件版本 3 或更高" (ABB10812.GSD). The DP-V1 file is
/// revision 3, declares MSAC1 and parses with gsd-parser.
#[test]
fn the_dpv1_file_is_revision_3_with_the_dpv1_keywords() {
    let text = dpv1_text();
    let value = |key: &str| {
        text.lines()
            .find(|l| l.split('=').next().is_some_and(|k| k.trim() == key))
            .and_then(|l| l.split('=').nth(1))
            .map(|v| v.trim().to_string())
    };
    assert_eq!(value("GSD_Revision").as_deref(), Some("3"));
    assert_eq!(value("DPV1_Slave").as_deref(), Some("1"));
    assert_eq!(value("C1_Read_Write_supp").as_deref(), Some("1"));
    assert_eq!(value("C1_Max_Data_Len").as_deref(), Some("240"));
    assert!(value("C1_Response_Timeout").is_some());
    assert_eq!(value("WD_Base_1ms_supp").as_deref(), Some("1"));
    gsd_parser::parser::parse(std::path::Path::new(profidrive::gsd::FILE_NAME_DPV1), &text)
        .unwrap_or_else(|e| panic!("{e}\n{text}"));
}

/// Its default User_Prm_Data is DPV1_Status_1-3 (DPV1_Enable) and the DP-V0 fields without
/// the reserved byte: a slave in DP-V1 mode takes it, and a tool's choice lands in the field.
#[test]
fn the_dpv1_user_parameters_are_what_a_dpv1_set_prm_carries() {
    let text = dpv1_text();
    let gsd = gsd_parser::parser::parse(std::path::Path::new("x.gsd"), &text).unwrap();
    let defaults = gsd_parser::PrmBuilder::new(&gsd.user_prm_data).into_bytes();
    assert_eq!(defaults[..3], [0x80, 0, 0]);
    assert_eq!(defaults[3..], UserPrm::DEFAULT.encode()[1..]);
    let mut builder = gsd_parser::PrmBuilder::new(&gsd.user_prm_data);
    builder.set_prm_from_text("Operation mode", "PROFIdrive (seed 004)");
    builder.set_prm("WrPZD3", 0xF105);
    let bytes = builder.as_bytes().to_vec();
    let prm = UserPrm::parse_dpv1(&bytes[3..]).unwrap();
    assert_eq!(
        (prm.operation, prm.wr_pzd[1].0),
        (OperationMode::Profidrive, 0xF105)
    );
    // Through the slave: Set_Prm with the DP-V1 layout, 51.21 = 1.
    let mut app = ProfidriveApp::new(MockDrive::default());
    app.set_dp_mode_dpv1(true);
    let mut slave = dp_slave::Slave::new(
        dp_slave::Config {
            address: 8,
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            no_add_chg: false,
            dpv1_status_bytes: true,
        },
        app,
    );
    let [hi, lo] = dp_consts::ADAPTER_IDENT_NUMBER.to_be_bytes();
    let mut set_prm = vec![0x88, 10, 10, 11, hi, lo, 0];
    set_prm.extend_from_slice(&bytes);
    let request = fdl::Repr::Data(fdl::DataRepr {
        da: 8,
        sa: 2,
        dsap: Some(fdl::Sap::SET_PRM),
        ssap: Some(fdl::Sap::MASTER_MS0),
        fc: fdl::FrameControl::Request {
            fcb: true,
            fcv: false,
            function: fdl::RequestFunction::SrdLow,
        },
        payload: &set_prm,
    });
    slave.process(dp_slave::Instant::ZERO, &request);
    assert!(!slave.prm_fault());
    assert!(slave.dpv1_enabled());
    assert_eq!(slave.app().prm().operation, OperationMode::Profidrive);
}

/// Issue 18: the RdPZD fields offer exactly the codes Set_Prm takes (seed 000's "Dx.xx, DE.xx":
/// D0.00-D0.99, D1.00-D1.49, DE.00-DE.25), and every one of them parses; a tool cannot pick a
/// code that gives Prm_Fault. The rated frequency's range is what Set_Prm takes too.
#[test]
fn every_value_a_tool_can_pick_is_taken_by_set_prm() {
    let gsd = parsed();
    let field = |name: &str| {
        gsd.user_prm_data
            .data_ref
            .iter()
            .map(|(_, d)| d)
            .find(|d| d.name == name)
            .unwrap_or_else(|| panic!("no field {name}"))
            .clone()
    };
    let rd = field("RdPZD2");
    let gsd_parser::PrmValueConstraint::Enum(codes) = &rd.constraint else {
        panic!("RdPZD2 is not a value set: {:?}", rd.constraint);
    };
    assert_eq!(codes.len(), 100 + 50 + 26);
    for &code in codes {
        let mut builder = gsd_parser::PrmBuilder::new(&gsd.user_prm_data);
        builder.set_prm("RdPZD2", code);
        assert!(
            UserPrm::parse(builder.as_bytes()).is_ok(),
            "RdPZD2 = {code:#06X} is offered but refused"
        );
    }
    for refused in [0xD0A0i64, 0xD150, 0xD200, 0xDD00, 0xDE26] {
        assert!(!rd.constraint.is_valid(refused), "{refused:#06X} offered");
    }
    let rated = field("Rated freq 0.01Hz (0 = F0.10)");
    assert_eq!(
        rated.constraint,
        gsd_parser::PrmValueConstraint::MinMax(0, i64::from(UserPrm::MAX_RATED_FREQUENCY))
    );
    let mut builder = gsd_parser::PrmBuilder::new(&gsd.user_prm_data);
    builder.set_prm("Rated freq 0.01Hz (0 = F0.10)", 6000);
    assert_eq!(
        UserPrm::parse(builder.as_bytes()).unwrap().rated_frequency,
        6000
    );
}

/// Seed 004 lines 1098-1113: in DP-V1 mode the extended diagnosis is a status block, so the
/// DP-V1 file declares its length (6 + 5) and names the flags where they are, at byte 10 of
/// Slave_Diag: a tool that reads the adapter's own diagnosis with the file's Unit_Diag_Bit
/// texts finds "Drive link temporarily lost" there. The DP-V0 file keeps 6 + 2, flags at byte 7.
#[test]
fn seed_004_lines_1098_1113_each_file_names_the_flags_where_its_diagnosis_has_them() {
    use profidrive::gsd::{write_variant, Variant, FILE_NAME, FILE_NAME_DPV1};
    for (variant, name, dpv1, len) in [
        (Variant::DpV0, FILE_NAME, false, 8),
        (Variant::DpV1, FILE_NAME_DPV1, true, 11),
    ] {
        let mut text = String::new();
        write_variant(&mut text, variant).unwrap();
        let gsd = gsd_parser::parser::parse(std::path::Path::new(name), &text)
            .unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(usize::from(gsd.max_diag_data_length), len, "{name}");
        // The adapter's own extended diagnosis with the drive link lost.
        let mut app = ProfidriveApp::new(MockDrive::default());
        assert!(app.accept_user_prm(&UserPrm::DEFAULT.encode()), "{name}");
        assert!(app.accept_cfg(Ppo::Ppo3.cfg()).is_some());
        // 51.21: the diagnosis takes the mode's form at once.
        app.set_dp_mode_dpv1(dpv1);
        let mut outputs = vec![0u8; Ppo::Ppo3.io_bytes()];
        outputs[..2].copy_from_slice(&0x047Fu16.to_be_bytes());
        // The flags the file's texts find in the adapter's diagnosis: none with the drive
        // link up, "temporarily lost" without it.
        let flags_named = |app: &mut ProfidriveApp<MockDrive>, at: u64| {
            app.outputs(dp_slave::Instant::from_micros(at), &outputs);
            app.service(dp_slave::Instant::from_micros(at + 10));
            let mut diag = [0u8; 32];
            let ext = app.ext_diag(&mut diag);
            assert_eq!(6 + ext, len, "{name}: {:02X?}", &diag[..ext]);
            // Unit_Diag_Bit counts from the byte after the header.
            gsd.unit_diag
                .bits
                .iter()
                .filter(|(bit, _)| {
                    let byte = 1 + (**bit / 8) as usize;
                    diag[..ext]
                        .get(byte)
                        .is_some_and(|b| b >> (**bit % 8) & 1 == 1)
                })
                .map(|(_, info)| info.text.clone())
                .collect::<Vec<String>>()
        };
        assert!(flags_named(&mut app, 0).is_empty(), "{name}");
        app.drive_mut().disconnected = true;
        assert_eq!(
            flags_named(&mut app, 100),
            ["Drive link temporarily lost"],
            "{name}"
        );
    }
}
